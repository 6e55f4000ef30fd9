//! ONNX import (docs/onnx.md): the bundled attention model exported through PyTorch gives the
//! native model's actions, maps, weights and `M`; foreign architectures load and step; every
//! broken graph is refused with one line naming what is wrong. The fixtures are made by
//! `export/make_fixtures.sh` (PyTorch is not needed here).

use std::path::Path;

use crate::common::{self, assert_bad_input, gs, stderr};

use groundscope::env::LevelConfig;
use groundscope::env::vocab;
use groundscope::env::world::Action;
use groundscope::policy::onnx::OnnxAgent;
use groundscope::policy::{self, Memory, Net, bundled};

use crate::common::onnx_fixture as fixture;

fn argmax(v: &[f32]) -> usize {
    v.iter()
        .enumerate()
        .fold(
            (0, f32::NEG_INFINITY),
            |b, (i, &x)| if x > b.1 { (i, x) } else { b },
        )
        .0
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn flat(m: &policy::ViewMap) -> Vec<f32> {
    m.iter().flatten().copied().collect()
}

#[test]
fn the_bundled_model_through_onnx_acts_and_attends_as_the_native_one() {
    let onnx = OnnxAgent::load(&fixture("bundled_attention.onnx")).unwrap();
    assert!(onnx.has_maps());
    let ckpt = bundled::load("bundled:attention").unwrap();
    let net = Net::new(ckpt.meta.model, ckpt.params.detached()).unwrap();
    let level = LevelConfig::default();
    let hid = net.cfg.lstm_hidden;
    assert_eq!(onnx.meta.memory_size, 2 * hid);
    assert_eq!(onnx.meta.level, level);
    let (mut steps, mut worst_logit, mut worst_map) = (0, 0f32, 0f32);
    for seed in 0..200 {
        let mut world = level.generate(seed).unwrap();
        let tokens = vocab::tokenize(&world.mission).unwrap();
        let mission = policy::episode_mission(&net, &tokens).unwrap();
        let mut memory = Memory::zeros(1, hid).unwrap();
        let mut onnx_memory = vec![0f32; 2 * hid];
        while !world.ended() {
            let obs = world.observe();
            let native = policy::act(
                &net,
                &[obs],
                &[&tokens],
                &memory,
                policy::ActOptions {
                    traces: true,
                    prepared: Some(&mission),
                    ..policy::ActOptions::default()
                },
            )
            .unwrap();
            let theirs = onnx
                .step(&[obs], &[world.agent_dir], &[&tokens], &onnx_memory, None)
                .unwrap();
            let (a, b) = (&native.logits[0], &theirs.logits[0]);
            worst_logit = worst_logit.max(max_diff(a, b));
            assert_eq!(
                argmax(a),
                argmax(b),
                "seed {seed} step {steps}: {a:?} vs {b:?}"
            );
            let trace = &native.traces.as_ref().unwrap()[0];
            let maps = &theirs.maps.as_ref().unwrap()[0];
            let words = maps.words.as_ref().unwrap();
            let weights = maps.weights.as_ref().unwrap();
            assert_eq!(words.len(), trace.words.len());
            for (w, (map, weight)) in trace.words.iter().zip(words.iter().zip(weights)) {
                worst_map = worst_map.max(max_diff(&flat(&w.map), &flat(map)));
                worst_map = worst_map.max((w.weight - weight).abs());
            }
            worst_map = worst_map.max(max_diff(
                &flat(&trace.combined),
                &flat(maps.combined.as_ref().unwrap()),
            ));
            memory = native.memory;
            onnx_memory = theirs.memory;
            let action = Action::from_index(argmax(a)).unwrap();
            world.step(action).unwrap();
            steps += 1;
        }
    }
    eprintln!("{steps} steps: logits within {worst_logit:e}, maps, w and M within {worst_map:e}");
    assert!(steps > 1000, "{steps} steps");
    assert!(worst_map < 1e-5, "maps, weights or M differ by {worst_map}");
    assert!(worst_logit < 1e-3, "logits differ by {worst_logit}");
}

#[test]
fn broken_graphs_are_refused_naming_what_is_wrong() {
    for (file, expect) in [
        (
            "bad_missing_input.onnx",
            "outputs \"memory_out\" but has no input \"memory\"",
        ),
        ("bad_missing_output.onnx", "no output \"logits\""),
        ("bad_shape.onnx", "output \"logits\""),
        ("bad_dtype.onnx", "input \"memory\" is int64"),
        ("bad_operator.onnx", "operator Loop"),
        ("bad_vocabulary.onnx", "no word \"key\""),
    ] {
        let path = fixture(file);
        let e = OnnxAgent::load(&path).unwrap_err().to_string();
        assert!(e.contains(expect), "{file}: {e}");
        assert!(e.contains(file), "{file}: names the file: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
        assert_eq!(e.matches("invalid input").count(), 1, "one prefix: {e}");
    }
    let nan = OnnxAgent::load(&fixture("bad_nan.onnx")).unwrap();
    let world = LevelConfig::default().generate(0).unwrap();
    let tokens = vocab::tokenize(&world.mission).unwrap();
    let m = nan.meta.memory_size;
    let e = nan
        .step(
            &[world.observe()],
            &[world.agent_dir],
            &[&tokens],
            &vec![0.0; m],
            None,
        )
        .unwrap_err()
        .to_string();
    assert!(e.contains("output logits holds NaN"), "{e}");
}

/// The first views, agent directions and missions of the default level's seeds `0..n`.
fn levels(
    n: u64,
) -> (
    Vec<groundscope::env::view::Observation>,
    Vec<u8>,
    Vec<Vec<u32>>,
) {
    let level = LevelConfig::default();
    let worlds: Vec<_> = (0..n).map(|s| level.generate(s).unwrap()).collect();
    let obs = worlds
        .iter()
        .map(groundscope::env::World::observe)
        .collect();
    let dirs = worlds.iter().map(|w| w.agent_dir).collect();
    let tokens = worlds
        .iter()
        .map(|w| vocab::tokenize(&w.mission).unwrap())
        .collect();
    (obs, dirs, tokens)
}

#[test]
fn the_mission_encoder_is_cut_off_and_runs_once_per_mission() {
    // Every fixture encodes its mission with a GRU that reads nothing else, so each one is
    // cut (docs/onnx.md#speed): the encoder runs for missions not seen before, once per
    // mission length in a step, and a kept mission gives the same numbers as a fresh one.
    let (obs, dirs, tokens) = levels(8);
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    let lengths = |rows: std::ops::Range<usize>| {
        let mut l: Vec<usize> = missions[rows].iter().map(|m| m.len()).collect();
        l.sort_unstable();
        l.dedup();
        l.len() as u64
    };
    let first = 0..5;
    let unseen = 5..8;
    assert!(
        missions[unseen.clone()]
            .iter()
            .any(|m| !missions[first.clone()].contains(m)),
        "levels 5-7 bring a mission levels 0-4 do not have"
    );
    for file in [
        "bundled_attention.onnx",
        "acmodel.onnx",
        "torch_reference.onnx",
    ] {
        let agent = OnnxAgent::load(&fixture(file)).unwrap();
        let m = agent.meta.memory_size;
        let step = |rows: std::ops::Range<usize>| {
            agent
                .step(
                    &obs[rows.clone()],
                    &dirs[rows.clone()],
                    &missions[rows.clone()],
                    &vec![0.1; rows.len() * m],
                    None,
                )
                .unwrap()
        };
        let a = step(first.clone());
        assert_eq!(
            agent.step_times().encoder_runs,
            lengths(first.clone()),
            "{file}"
        );
        let b = step(first.clone());
        assert_eq!(
            agent.step_times().encoder_runs,
            lengths(first.clone()),
            "{file}: kept"
        );
        assert_eq!(a.logits, b.logits, "{file}");
        assert_eq!(a.memory, b.memory, "{file}");
        agent.forget_missions();
        let c = step(first.clone());
        assert_eq!(
            agent.step_times().encoder_runs,
            2 * lengths(first.clone()),
            "{file}"
        );
        assert_eq!(a.logits, c.logits, "{file}: encoded again");
        step(unseen.clone());
        assert!(
            agent.step_times().encoder_runs > 2 * lengths(first.clone()),
            "{file}"
        );
    }
}

#[test]
fn foreign_architectures_load_and_step_in_batches_of_mixed_mission_lengths() {
    let (obs, dirs, tokens) = levels(6);
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    for (file, maps) in [("acmodel.onnx", false), ("torch_reference.onnx", true)] {
        let agent = OnnxAgent::load(&fixture(file)).unwrap();
        assert_eq!(agent.has_maps(), maps, "{file}");
        let m = agent.meta.memory_size;
        let batch = agent
            .step(&obs, &dirs, &missions, &vec![0.0; 6 * m], None)
            .unwrap();
        // Each row as its own batch gives the same numbers: rows are not mixed up when
        // missions of different lengths are grouped.
        for r in 0..6 {
            let one = agent
                .step(
                    &obs[r..=r],
                    &dirs[r..=r],
                    &missions[r..=r],
                    &vec![0.0; m],
                    None,
                )
                .unwrap();
            assert!(
                max_diff(&one.logits[0], &batch.logits[r]) < 1e-5,
                "{file} row {r}"
            );
            assert!(max_diff(&one.memory, &batch.memory[r * m..(r + 1) * m]) < 1e-5);
        }
    }
}

#[test]
fn replay_runs_an_onnx_file_as_it_runs_a_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let (ours, theirs) = (dir.path().join("native.json"), dir.path().join("onnx.json"));
    let bundled = fixture("bundled_attention.onnx");
    for (spec, out) in [
        ("bundled:attention", &ours),
        (bundled.to_str().unwrap(), &theirs),
    ] {
        let o = gs(&[
            "replay",
            "--checkpoint",
            spec,
            "--seed",
            "5",
            "--trace",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{spec}: {}", stderr(&o));
    }
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (a, b) = (read(&ours), read(&theirs));
    let actions = |v: &serde_json::Value| -> Vec<u64> {
        v["steps"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["action"].as_u64().unwrap())
            .collect()
    };
    assert_eq!(actions(&a), actions(&b));
    assert_eq!(a["variant"], b["variant"]);
    let first = |v: &serde_json::Value| {
        v["steps"][0]["attention"]["combined"][6][3]
            .as_f64()
            .unwrap()
    };
    assert!((first(&a) - first(&b)).abs() < 1e-5);
    // A graph without maps records too (Rerun and MCAP), as a baseline would.
    let (rrd, mcap) = (dir.path().join("ac.rrd"), dir.path().join("ac.mcap"));
    let o = gs(&[
        "replay",
        "--checkpoint",
        fixture("acmodel.onnx").to_str().unwrap(),
        "--episodes",
        "2",
        "--save",
        rrd.to_str().unwrap(),
        "--mcap",
        mcap.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::metadata(&rrd).unwrap().len() > 1000);
    assert!(std::fs::metadata(&mcap).unwrap().len() > 1000);
    // A broken graph: one line naming the operator, exit 2, nothing written.
    let bad = dir.path().join("bad.json");
    assert_bad_input(
        &gs(&[
            "replay",
            "--checkpoint",
            fixture("bad_operator.onnx").to_str().unwrap(),
            "--trace",
            bad.to_str().unwrap(),
        ]),
        "operator Loop",
    );
    assert!(!bad.exists());
}

#[test]
fn eval_of_the_onnx_export_reports_what_the_native_model_measures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("eval");
    let bundled = fixture("bundled_attention.onnx");
    let acmodel = fixture("acmodel.onnx");
    let o = gs(&[
        "eval",
        "--checkpoint",
        bundled.to_str().unwrap(),
        "--checkpoint",
        "bundled:attention",
        "--checkpoint",
        acmodel.to_str().unwrap(),
        "--sizes",
        "8,12",
        "--objects",
        "4,8",
        "--seeds",
        "2",
        "--episodes",
        "20",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let cells = report["cells"].as_array().unwrap();
    let of = |name: &str| -> Vec<&serde_json::Value> {
        cells.iter().filter(|c| c["checkpoint"] == name).collect()
    };
    let (theirs, ours) = (of(bundled.to_str().unwrap()), of("bundled:attention"));
    assert_eq!(theirs.len(), 4);
    for (a, b) in theirs.iter().zip(&ours) {
        for key in ["success", "reward", "length"] {
            assert_eq!(a[key], b[key], "{key} in S{} N{}", a["size"], a["objects"]);
        }
        let (x, y) = (
            a["accuracy"]["object"]["acc"]["mean"].as_f64().unwrap(),
            b["accuracy"]["object"]["acc"]["mean"].as_f64().unwrap(),
        );
        assert!((x - y).abs() < 1e-9, "object acc {x} vs {y}");
        assert_eq!(a["variant"], "attention");
    }
    // A graph without maps is evaluated as a baseline: no accuracies, failure classes without
    // `grounding`.
    for c in of(acmodel.to_str().unwrap()) {
        assert!(c["accuracy"].is_null(), "{c}");
        assert!(c["failure_classes"].get("grounding").is_none(), "{c}");
    }
}

#[test]
fn validate_scores_the_onnx_export_as_the_native_checkpoint() {
    let bundled = fixture("bundled_attention.onnx");
    let o = gs(&[
        "validate",
        bundled.to_str().unwrap(),
        "bundled:attention",
        "--episodes",
        "60",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = common::stdout(&o);
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 2, "{text}");
    // Episodes, success, reward, length and the six accuracies; not the name, counters or time.
    assert_eq!(rows[0][3..13], rows[1][3..13], "{text}");
    assert_eq!(
        rows[0][1..3],
        ["0", "0"],
        "an imported graph has no training counters"
    );
}

/// A sidecar key the contract does not know is not silent: a one-line warning names it.
#[test]
fn an_unknown_sidecar_key_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("agent.onnx");
    std::fs::copy(fixture("minimal.onnx"), &graph).unwrap();
    std::fs::write(dir.path().join("agent.onnx.json"), r#"{"memroy_size": 8}"#).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args([
            "replay",
            "--checkpoint",
            graph.to_str().unwrap(),
            "--seed",
            "1",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("unknown key \"memroy_size\" ignored"), "{err}");
}

/// Issue #42 item 8, a hand-exported agent as itself: its metadata name is shown beside its
/// file (replay, the trace, report.json), and the trace records the ids the graph received
/// (numbered by its own vocabulary) beside groundscope's.
#[test]
fn a_hand_exported_graph_is_shown_and_traced_as_itself() {
    let graph = fixture("renamed.onnx");
    let agent = OnnxAgent::load(&graph).unwrap();
    let shown = "tiny policy (test) (renamed.onnx)";
    assert_eq!(agent.display_name(), shown);
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.json");
    let o = gs(&[
        "replay",
        "--checkpoint",
        graph.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        common::stdout(&o).starts_with(&format!("{shown}, baseline on ")),
        "{}",
        common::stdout(&o)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    assert_eq!(json["model_name"], shown);
    let words: Vec<&str> = json["tokens"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    let theirs: Vec<i64> = words
        .iter()
        .map(|w| agent.meta.vocabulary.iter().position(|v| v == w).unwrap() as i64)
        .collect();
    let got: Vec<i64> = json["graph_token_ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_i64().unwrap())
        .collect();
    assert_eq!(got, theirs, "the ids the graph received, by its vocabulary");
    let ours: Vec<i64> = json["token_ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_i64().unwrap())
        .collect();
    assert_ne!(got, ours, "the fixture numbers its words differently");
    // A native checkpoint's trace has neither: its ids are groundscope's.
    let native = dir.path().join("n.json");
    let o = gs(&["replay", "--trace", native.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&native).unwrap()).unwrap();
    assert!(json.get("graph_token_ids").is_none() && json.get("model_name").is_none());

    let out = dir.path().join("report");
    let mut args = vec![
        "eval",
        "--quiet",
        "--checkpoint",
        graph.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(common::SMALL_SWEEP);
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["checkpoints"][0]["model_name"], shown);
}

/// What a hand export gets wrong is named with its cause and what to do: an opset newer than
/// the runtime's (tract used to fail with `Impossible to unify 0 with 2` on a Gemm), a batch
/// size fixed inside the graph (`Impossible to unify …Sym(B)… with Val(…)`), a misnamed
/// input; inputs that declare fixed sizes run, with a warning.
#[test]
fn hand_export_mistakes_are_named_with_their_cause() {
    for (file, expect) in [
        (
            "bad_opset.onnx",
            "ONNX opset 21 is outside the opsets groundscope's runtime supports (9–18); export with opset_version=17",
        ),
        (
            "bad_fixed_batch.onnx",
            "the batch dimension is fixed inside the graph at node \"reshape_fixed_batch\" (Reshape)",
        ),
        (
            "bad_input_name.onnx",
            "no input \"image\"; its input \"obs\" is not in the contract (the contract's inputs: image, and mission and memory where the model reads them; optionally direction, and combined_override with override_weight",
        ),
    ] {
        let path = fixture(file);
        let o = gs(&["replay", "--checkpoint", path.to_str().unwrap()]);
        assert_bad_input(&o, expect);
    }
    let o = gs(&[
        "replay",
        "--checkpoint",
        &fixture("bad_fixed_batch.onnx").to_string_lossy(),
    ]);
    assert!(
        stderr(&o).contains("dynamic_axes"),
        "says what to do: {}",
        stderr(&o)
    );
    let o = gs(&[
        "replay",
        "--checkpoint",
        &fixture("fixed_dims.onnx").to_string_lossy(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("groundscope: warning: ")
            && err.contains("image batch 1")
            && err.contains("mission length 5"),
        "{err}"
    );
}
