//! `groundscope bench policy`'s and `bench record --level`'s JSON lines: every measurement
//! they promise.

use crate::common::{self, gs};

#[test]
fn bench_policy_reports_inference_training_and_the_matmul_rate() {
    let o = gs(&["bench", "policy", "--secs", "0.02"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let lines: Vec<serde_json::Value> = String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let sizes = |kind: &str, key: &str| -> Vec<u64> {
        lines
            .iter()
            .filter(|j| j["bench"] == kind)
            .map(|j| j[key].as_u64().unwrap())
            .collect()
    };
    assert_eq!(sizes("policy_inference", "batch"), [1, 16, 256]);
    assert_eq!(
        sizes("policy_train_fwd_bwd", "minibatch_frames"),
        [128, 256, 2048]
    );
    assert_eq!(sizes("policy_matmul", "rows"), [128, 256, 2048]);
    for j in lines.iter().filter(|j| j["bench"] == "policy_matmul") {
        // The LSTM input projection of the default model: 49 cells × 16 channels in, 4 × 128
        // gates out.
        assert_eq!(
            (j["inner"].as_u64(), j["columns"].as_u64()),
            (Some(784), Some(512))
        );
        let g = j["gflops"].as_f64().unwrap();
        assert!(g.is_finite() && g > 0.0, "{j}");
    }
    assert_eq!(lines.len(), 9, "no other lines");
}

/// `bench record --level`: one long episode recorded in each format, each in its own process,
/// beside running alone: a JSON line each with the time to write, the bytes and the peak
/// memory against the target.
#[test]
fn bench_record_long_gives_each_formats_peak_memory() {
    let o = gs(&[
        "bench",
        "record",
        "--level",
        "BabyAI-GoToLocal-v0",
        "--seed",
        "1",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let lines: Vec<serde_json::Value> = String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let formats: Vec<&str> = lines
        .iter()
        .map(|j| j["format"].as_str().unwrap())
        .collect();
    assert_eq!(formats, ["none", "rrd", "mcap"]);
    let steps = lines[0]["steps"].as_u64().unwrap();
    for j in &lines {
        assert_eq!(j["bench"], "record_long");
        assert_eq!(j["steps"].as_u64().unwrap(), steps, "one episode: {j}");
        assert!(j["peak_rss_bytes"].as_u64().unwrap() > 0, "{j}");
        assert_eq!(j["target_peak_bytes"], 300 * 1024 * 1024);
        let written = j["bytes"].as_u64().unwrap();
        assert_eq!(written > 0, j["format"] != "none", "{j}");
    }
    let bad = gs(&["bench", "record", "--level", "BabyAI-GoToLocl-v0"]);
    common::assert_bad_input(&bad, "BabyAI-GoToLocl-v0");
}

/// `bench sweep` runs `eval` as a user does and splits its wall time into the episodes and
/// the rest; a shrunk sweep keeps the test short.
#[test]
fn bench_sweep_times_the_default_evaluation_and_its_parts() {
    let o = gs(&["bench", "sweep", "--seeds", "1", "--episodes", "3"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let j: serde_json::Value =
        serde_json::from_str(String::from_utf8(o.stdout).unwrap().trim()).expect("one JSON line");
    assert_eq!(j["bench"], "sweep");
    // The default sweep: both bundled models on 20 cells.
    assert_eq!(j["cells"].as_u64(), Some(40));
    assert_eq!(j["episodes"].as_u64(), Some(120));
    let (total, episodes, rest) = (
        j["total_secs"].as_f64().unwrap(),
        j["episodes_secs"].as_f64().unwrap(),
        j["rest_secs"].as_f64().unwrap(),
    );
    assert!(episodes > 0.0 && episodes <= total, "{j}");
    assert!((episodes + rest - total).abs() < 1e-6, "{j}");
    common::assert_bad_input(&gs(&["bench", "sweep", "--episodes", "0"]), "--episodes 0");
}
