//! Faithfulness and saliency for imported graphs (docs/onnx.md, docs/faithfulness.md): the
//! bundled model exported to ONNX (with the intervention inputs) gets the native model's
//! faithfulness report; a graph without maps is explained by occlusion — in traces, in `eval
//! --saliency`'s failure classes — and its occlusion maps equal a direct recomputation.

use std::path::Path;

use crate::common::{assert_bad_input, gs, stderr};
use serde_json::Value;

use crate::common::onnx_fixture as fixture;

fn read(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// The largest difference between the numbers of `a` and `b`, which must have the same shape
/// (keys, lengths, strings, booleans, nulls) except under the keys in `skip`.
fn max_number_diff(a: &Value, b: &Value, skip: &[&str], at: &str) -> f64 {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => (x.as_f64().unwrap() - y.as_f64().unwrap()).abs(),
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}: lengths differ");
            x.iter()
                .zip(y)
                .enumerate()
                .map(|(i, (x, y))| max_number_diff(x, y, skip, &format!("{at}[{i}]")))
                .fold(0.0, f64::max)
        }
        (Value::Object(x), Value::Object(y)) => {
            let keys = |o: &serde_json::Map<String, Value>| -> Vec<String> {
                o.keys()
                    .filter(|k| !skip.contains(&k.as_str()))
                    .cloned()
                    .collect()
            };
            assert_eq!(keys(x), keys(y), "{at}: keys differ");
            keys(x)
                .iter()
                .map(|k| max_number_diff(&x[k], &y[k], skip, &format!("{at}.{k}")))
                .fold(0.0, f64::max)
        }
        _ => {
            assert_eq!(a, b, "{at}");
            0.0
        }
    }
}

#[test]
fn faithfulness_of_the_onnx_export_equals_the_native_models() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("faith");
    let bundled = fixture("bundled_attention.onnx");
    let o = gs(&[
        "faithfulness",
        "--checkpoint",
        bundled.to_str().unwrap(),
        "--checkpoint",
        "bundled:attention",
        "--seeds",
        "2",
        "--episodes",
        "4",
        "--jobs",
        "1",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let report = read(&out.join("faithfulness.json"));
    let entries = report["checkpoints"].as_array().unwrap();
    assert_eq!(entries.len(), 2);
    // Every part ran for the graph too: the override inputs make the interventions and
    // closed-loop re-runs possible.
    for part in ["interventions", "closed_loop", "counterfactuals"] {
        let v = &entries[0][part];
        assert!(v.as_object().is_some_and(|o| !o.is_empty()), "{part}: {v}");
    }
    // The same episodes, the same measures: the graph's probabilities differ from the native
    // ones by ~1e-6, so every mean and std within 1e-4.
    let d = max_number_diff(&entries[0], &entries[1], &["checkpoint"], "checkpoints");
    assert!(d < 1e-4, "largest difference {d}");
}

#[test]
fn a_graph_without_maps_gets_occlusion_maps_equal_to_a_direct_recomputation() {
    let dir = tempfile::tempdir().unwrap();
    let acmodel = fixture("acmodel.onnx");
    let (trace, rrd, mcap) = (
        dir.path().join("t.json"),
        dir.path().join("t.rrd"),
        dir.path().join("t.mcap"),
    );
    let o = gs(&[
        "replay",
        "--checkpoint",
        acmodel.to_str().unwrap(),
        "--seed",
        "4",
        "--faithfulness",
        "--trace",
        trace.to_str().unwrap(),
        "--save",
        rrd.to_str().unwrap(),
        "--mcap",
        mcap.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::metadata(&rrd).unwrap().len() > 1000);
    assert!(std::fs::metadata(&mcap).unwrap().len() > 1000);
    let nonzero = super::occlusion::check_trace(&acmodel, &read(&trace), usize::MAX, "acmodel");
    assert!(nonzero > 0, "some cell matters to the policy");
}

#[test]
fn faithfulness_and_eval_explain_a_graph_without_maps_by_occlusion() {
    let dir = tempfile::tempdir().unwrap();
    let acmodel = fixture("acmodel.onnx");
    let spec = acmodel.to_str().unwrap();
    let out = dir.path().join("faith");
    let o = gs(&[
        "faithfulness",
        "--checkpoint",
        spec,
        "--seeds",
        "1",
        "--episodes",
        "4",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let report = read(&out.join("faithfulness.json"));
    let entry = &report["checkpoints"][0];
    assert_eq!(entry["variant"], "baseline");
    assert!(entry["analysed_steps"].as_u64().unwrap() > 0, "{entry}");
    // Counterfactual worlds run (tracking M is not measured without M); the closed loop
    // occludes the input, since M cannot be set.
    let cf = entry["counterfactuals"].as_object().unwrap();
    assert!(!cf.is_empty(), "{entry}");
    for (name, c) in cf {
        assert!(c["tracking"]["value"]["mean"].is_null(), "{name}: {c}");
    }
    let loops: Vec<&String> = entry["closed_loop"].as_object().unwrap().keys().collect();
    assert_eq!(
        loops,
        ["none", "occlude_random", "occlude_salient"],
        "{entry}"
    );
    // A bad request is still one line and leaves nothing.
    let refused = dir.path().join("refused");
    assert_bad_input(
        &gs(&[
            "faithfulness",
            "--checkpoint",
            spec,
            "--seeds",
            "0",
            "--out",
            refused.to_str().unwrap(),
        ]),
        "--seeds",
    );
    assert!(!refused.exists());
    // A graph that outputs NaN stops the run in one line, and the new directory goes too.
    let nan = dir.path().join("nan");
    assert_bad_input(
        &gs(&[
            "faithfulness",
            "--checkpoint",
            fixture("bad_nan.onnx").to_str().unwrap(),
            "--seeds",
            "1",
            "--episodes",
            "1",
            "--out",
            nan.to_str().unwrap(),
        ]),
        "NaN",
    );
    assert!(!nan.exists());
    // eval --saliency: the occlusion map stands in for M, so `grounding` is decided.
    let eval = dir.path().join("eval");
    let o = gs(&[
        "eval",
        "--checkpoint",
        spec,
        "--sizes",
        "8",
        "--objects",
        "4",
        "--seeds",
        "1",
        "--episodes",
        "12",
        "--saliency",
        "--quiet",
        "--out",
        eval.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let report = read(&eval.join("report.json"));
    assert_eq!(report["saliency"], true);
    let cell = &report["cells"][0];
    let classes = cell["failure_classes"].as_object().unwrap();
    assert!(classes.contains_key("grounding"), "{cell}");
    let failed: u64 = classes.values().map(|v| v.as_u64().unwrap()).sum();
    let success = cell["success"]["mean"].as_f64().unwrap();
    assert_eq!(failed, ((1.0 - success) * 12.0).round() as u64, "{cell}");
}
