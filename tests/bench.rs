//! `groundscope bench policy`'s JSON lines: every measurement it promises, each a positive rate.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "tests fail loudly on what they check"
)]

mod common;

use common::gs;

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
