//! `train --layout-path` (issue #64): the LSTM reads the layout beside `M`'s filter, the
//! layout says nothing of which object or door is which, a parent grown with it acts as before,
//! and the option is kept, refused and named like the other model options.

use crate::common::worlds::{babyai, first_views};
use crate::common::{self, assert_bad_input, gs, stderr};
use candle_core::Tensor;
use groundscope::env::view::Observation;
use groundscope::policy::obs::{CellCodes, TokenBatch};
use groundscope::policy::ppo::{PpoConfig, Trainer};
use groundscope::policy::{Memory, ModelConfig, Net, Params, Variant};

/// Logits and values of one step from zero memory for `views`.
fn step(net: &Net, cfg: &ModelConfig, obs: &[Observation], tokens: &[Vec<u32>]) -> Vec<f32> {
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    let mi = net
        .mission_inputs(&TokenBatch::new(&missions).unwrap())
        .unwrap();
    let mem = Memory::zeros(obs.len(), cfg.lstm_hidden).unwrap();
    let (logits, values, _, vis) = net.step(&CellCodes::new(obs), &mi, &mem).unwrap();
    assert_eq!(vis.x.dim(1).unwrap(), cfg.lstm_input_size());
    let mut out: Vec<f32> = logits.flatten_all().unwrap().to_vec1().unwrap();
    out.extend(values.to_vec1::<f32>().unwrap());
    out
}

#[test]
fn a_parent_grown_with_the_layout_path_acts_exactly_as_before() {
    let (cfg, parent_params) = super::plain_babyai_parent();
    assert!(!cfg.layout_path);
    let (grown_cfg, grown) = parent_params.with_layout_path(&cfg, 3).unwrap();
    assert!(grown_cfg.layout_path);
    assert_eq!(
        grown.count(),
        parent_params.count() + 4 * cfg.lstm_hidden * 49 * cfg.conv_channels + {
            let k = cfg.conv_channels;
            k * groundscope::policy::obs::CELL_CODES * 9 + k
        }
    );
    let (obs, tokens) = first_views(&babyai("BabyAI-PutNextLocal-v0"), 8);
    let before = step(
        &Net::new(cfg, parent_params.detached()).unwrap(),
        &cfg,
        &obs,
        &tokens,
    );
    let after = step(
        &Net::new(grown_cfg, grown.detached()).unwrap(),
        &grown_cfg,
        &obs,
        &tokens,
    );
    assert_eq!(before.len(), after.len());
    for (a, b) in before.iter().zip(&after) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
    // Growing twice changes nothing more.
    let (again_cfg, again) = grown.with_layout_path(&grown_cfg, 4).unwrap();
    assert_eq!(again_cfg, grown_cfg);
    assert_eq!(again.count(), grown.count());
}

#[test]
fn the_layout_hides_which_object_or_door_is_which_and_keeps_where_they_stand() {
    // Codes are (type, 11 + colour, 17 + state) per cell.
    let (mut obs, _) = first_views(&babyai("BabyAI-GoToDoor-v0"), 30);
    obs.extend(first_views(&babyai("BabyAI-GoToLocal-v0"), 30).0);
    let codes = CellCodes::new(&obs);
    let layout = codes.layout();
    let (mut objects, mut doors) = (0, 0);
    for (c, l) in codes
        .as_slice()
        .chunks_exact(3)
        .zip(layout.as_slice().chunks_exact(3))
    {
        match c[0] {
            5..=7 => {
                objects += 1;
                assert_eq!(l, [u8::MAX, u8::MAX, c[2]], "object cell {c:?}");
            }
            4 => {
                doors += 1;
                assert_eq!(l, [4, u8::MAX, c[2]], "door cell {c:?}");
            }
            _ => assert_eq!(l, c, "layout cell"),
        }
    }
    assert!(
        objects > 10 && doors > 10,
        "{objects} objects, {doors} doors"
    );
}

#[test]
fn the_layout_encoder_learns_from_scratch() {
    // A few updates from scratch move the layout encoder, and the LSTM reads its 49·K
    // features after the filter's.
    let level = babyai("BabyAI-GoToLocal-v0");
    let cfg = ModelConfig {
        layout_path: true,
        vocab_size: ModelConfig::vocab_size_for(&level),
        lstm_hidden: 32,
        ..ModelConfig::new(Variant::Attention)
    };
    let params = Params::init(&cfg, 9).unwrap();
    let get = |p: &Params, n: &str| -> Vec<f32> {
        p.vars[n]
            .as_tensor()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap()
    };
    let w0 = get(&params, "layout.conv.weight");
    let ppo = PpoConfig {
        procs: 4,
        frames_per_proc: 16,
        batch_size: 32,
        imitate: true,
        ..PpoConfig::default()
    };
    let mut t = Trainer::new(cfg, level, ppo, params, 1).unwrap();
    for _ in 0..3 {
        t.update().unwrap();
    }
    let w1 = get(&t.params, "layout.conv.weight");
    assert!(
        w0.iter().zip(&w1).any(|(a, b)| a != b),
        "the layout encoder trains"
    );
    let ih: Tensor = t.params.vars["lstm.weight_ih_l0"].as_tensor().clone();
    assert_eq!(ih.dim(1).unwrap(), cfg.lstm_input_size());
    assert_eq!(cfg.lstm_input_size(), 2 * cfg.filter_input_size());
}

#[test]
fn the_option_is_named_kept_and_refused_like_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let (run, plain) = (dir.path().join("lp"), dir.path().join("plain"));
    let (run_s, plain_s) = (run.to_str().unwrap(), plain.to_str().unwrap());
    let meta = |dir: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join("model.json")).unwrap()).unwrap()
    };
    // The baseline has no filter to go round.
    let baseline: Vec<&str> = common::small_run(run_s, "64", &["--layout-path"])
        .into_iter()
        .map(|a| if a == "attention" { "baseline" } else { a })
        .collect();
    let o = gs(&baseline);
    assert_bad_input(&o, "layout_path");
    assert!(!run.exists(), "a refused run leaves nothing");
    let train = |args: Vec<&str>| {
        let o = gs(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    };
    train(common::small_run(plain_s, "64", &[]));
    assert!(meta(&plain)["model"].get("layout_path").is_none());
    // A warm start may add it (the parent grows), and the child keeps it on resume.
    train(common::small_run(
        run_s,
        "128",
        &["--init", plain_s, "--layout-path"],
    ));
    assert_eq!(meta(&run)["model"]["layout_path"], true);
    train(common::small_run(run_s, "192", &["--resume"]));
    assert_eq!(meta(&run)["model"]["layout_path"], true);
    // Its children keep it without the flag.
    let child = dir.path().join("child");
    train(common::small_run(
        child.to_str().unwrap(),
        "256",
        &["--init", run_s],
    ));
    assert_eq!(meta(&child)["model"]["layout_path"], true);
    // Its checkpoint plays: an evaluation and a replay read it.
    let report = dir.path().join("report");
    let o = gs(&[
        "eval",
        "--checkpoint",
        run_s,
        "--sizes",
        "5",
        "--objects",
        "1",
        "--seeds",
        "1",
        "--episodes",
        "2",
        "--out",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}
