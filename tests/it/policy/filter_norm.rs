//! `train --filter-norm` (issue #64): the filter's features keep the view's norm however
//! sharp `M` is, a uniform `M` changes nothing, the training and acting paths agree, and the
//! option is kept, refused and named like the other model options.

use crate::common::evals::Eval;
use crate::common::worlds::{babyai, first_views};
use crate::common::{self, assert_bad_input, gs, stderr};
use candle_core::{DType, Device, Tensor};
use groundscope::policy::attention::Intervention;
use groundscope::policy::obs::{CellCodes, TokenBatch};
use groundscope::policy::ppo::{PpoConfig, Trainer};
use groundscope::policy::{Memory, ModelConfig, Net, Params, Variant};

/// Each row's Euclidean norm of a (B, …) tensor.
fn row_norms(t: &Tensor) -> Vec<f32> {
    let b = t.dim(0).unwrap();
    let rows: Vec<Vec<f32>> = t.reshape((b, ())).unwrap().to_vec2().unwrap();
    rows.iter()
        .map(|r| r.iter().map(|x| x * x).sum::<f32>().sqrt())
        .collect()
}

/// A BabyAI network without the option ([`super::plain_babyai_parent`]), and the same with it.
fn nets() -> (Net, Net, ModelConfig) {
    let (cfg, parent_params) = super::plain_babyai_parent();
    assert!(!cfg.filter_norm);
    let normed = ModelConfig {
        filter_norm: true,
        ..cfg
    };
    (
        Net::new(cfg, parent_params.detached()).unwrap(),
        Net::new(normed, parent_params.detached()).unwrap(),
        normed,
    )
}

#[test]
fn the_filter_keeps_the_views_norm_and_a_uniform_map_changes_nothing() {
    let (plain, normed, cfg) = nets();
    let (obs, tokens) = first_views(&babyai("BabyAI-PutNextLocal-v0"), 6);
    let b = obs.len();
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    let tb = TokenBatch::new(&missions).unwrap();
    let codes = CellCodes::new(&obs);
    let mem = Memory::zeros(b, cfg.lstm_hidden).unwrap();
    let o_norms = row_norms(&normed.cells(&codes).unwrap());
    let x = |net: &Net, m: Option<Vec<f32>>| -> Tensor {
        let mi = net.mission_inputs(&tb).unwrap();
        let iv = m.map(|m| Intervention::SetM(Tensor::from_vec(m, (b, 49), &Device::Cpu).unwrap()));
        net.step_with(&codes, &mi, &mem, iv.as_ref()).unwrap().3.x
    };
    // A map on one cell: without the option that cell passes at 49 times its scale.
    let mut one = vec![0f32; b * 49];
    for r in 0..b {
        one[r * 49 + 17] = 1.0;
    }
    for m in [None, Some(one.clone())] {
        for (got, want) in row_norms(&x(&normed, m.clone())).iter().zip(&o_norms) {
            assert!(
                (got - want).abs() <= 1e-3 * want.max(1.0),
                "{got} vs {want}"
            );
        }
    }
    let sharp_plain = row_norms(&x(&plain, Some(one)));
    assert!(
        sharp_plain.iter().zip(&o_norms).any(|(s, o)| *s > 2.0 * o),
        "{sharp_plain:?} against {o_norms:?}"
    );
    // A uniform map passes `Õ` unchanged either way.
    let uniform = || Some(vec![1.0 / 49.0; b * 49]);
    let (p, n): (Vec<f32>, Vec<f32>) = (
        x(&plain, uniform())
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap(),
        x(&normed, uniform())
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap(),
    );
    for (a, c) in p.iter().zip(&n) {
        assert!((a - c).abs() < 1e-4, "{a} vs {c}");
    }
}

#[test]
fn the_training_path_acts_as_the_acting_path() {
    let (_, normed, cfg) = nets();
    let (obs, tokens) = first_views(&babyai("BabyAI-GoToDoor-v0"), 6);
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    let tb = TokenBatch::new(&missions).unwrap();
    let codes = CellCodes::new(&obs);
    let mem = Memory::zeros(obs.len(), cfg.lstm_hidden).unwrap();
    let acting = normed
        .step(&codes, &normed.mission_inputs(&tb).unwrap(), &mem)
        .unwrap()
        .0;
    let training = normed
        .step_untraced(&codes, &normed.mission_inputs_keyed(&tb).unwrap(), &mem)
        .unwrap()
        .0;
    let (a, t): (Vec<f32>, Vec<f32>) = (
        acting.flatten_all().unwrap().to_vec1().unwrap(),
        training.flatten_all().unwrap().to_vec1().unwrap(),
    );
    for (x, y) in a.iter().zip(&t) {
        assert!((x - y).abs() < 1e-3, "{x} vs {y}");
    }
}

#[test]
fn a_model_with_it_trains_without_nans() {
    let level = babyai("BabyAI-GoToLocal-v0");
    let cfg = ModelConfig {
        filter_norm: true,
        vocab_size: ModelConfig::vocab_size_for(&level),
        lstm_hidden: 32,
        ..ModelConfig::new(Variant::Attention)
    };
    let params = Params::init(&cfg, 9).unwrap();
    let ppo = PpoConfig {
        procs: 4,
        frames_per_proc: 16,
        batch_size: 32,
        imitate: true,
        ground_loss: 1.0,
        ..PpoConfig::default()
    };
    let mut t = Trainer::new(cfg, level, ppo, params, 1).unwrap();
    for _ in 0..3 {
        let log = t.update().unwrap();
        assert!(log.policy_loss.is_finite() && log.ground_loss.is_finite());
    }
    for (name, v) in &t.params.vars {
        let sum = v
            .as_tensor()
            .to_dtype(DType::F32)
            .unwrap()
            .sum_all()
            .unwrap();
        assert!(sum.to_scalar::<f32>().unwrap().is_finite(), "{name}");
    }
}

#[test]
fn the_option_is_named_kept_and_refused_like_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let (run, plain) = (dir.path().join("fn"), dir.path().join("plain"));
    let (run_s, plain_s) = (run.to_str().unwrap(), plain.to_str().unwrap());
    let meta = |dir: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join("model.json")).unwrap()).unwrap()
    };
    // The baseline has no filter.
    let baseline: Vec<&str> = common::small_run(run_s, "64", &["--filter-norm"])
        .into_iter()
        .map(|a| if a == "attention" { "baseline" } else { a })
        .collect();
    assert_bad_input(&gs(&baseline), "filter_norm");
    assert!(!run.exists(), "a refused run leaves nothing");
    let train = |args: Vec<&str>| {
        let o = gs(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    };
    train(common::small_run(plain_s, "64", &[]));
    assert!(meta(&plain)["model"].get("filter_norm").is_none());
    // A resume may not add it: the run's weights were trained without it.
    let o = gs(&common::small_run(
        plain_s,
        "128",
        &["--resume", "--filter-norm"],
    ));
    assert!(!o.status.success());
    assert!(stderr(&o).contains("filter-norm"), "{}", stderr(&o));
    // A warm start may, and the child keeps it on resume and passes it on.
    train(common::small_run(
        run_s,
        "128",
        &["--init", plain_s, "--filter-norm"],
    ));
    assert_eq!(meta(&run)["model"]["filter_norm"], true);
    train(common::small_run(run_s, "192", &["--resume"]));
    assert_eq!(meta(&run)["model"]["filter_norm"], true);
    let child = dir.path().join("child");
    train(common::small_run(
        child.to_str().unwrap(),
        "256",
        &["--init", run_s],
    ));
    assert_eq!(meta(&child)["model"]["filter_norm"], true);
    // A warm start may grow the search query beside it.
    let search = dir.path().join("search");
    train(common::small_run(
        search.to_str().unwrap(),
        "256",
        &["--init", plain_s, "--search-query", "--filter-norm"],
    ));
    assert_eq!(meta(&search)["model"]["search_query"], true);
    assert_eq!(meta(&search)["model"]["filter_norm"], true);
}

#[test]
fn a_parent_grown_with_the_search_query_acts_exactly_as_before() {
    let (cfg, parent_params) = super::plain_babyai_parent();
    let (lp_cfg, lp) = parent_params.with_layout_path(&cfg, 3).unwrap();
    let (grown_cfg, grown) = lp.with_search_query(&lp_cfg, 4).unwrap();
    assert!(grown_cfg.search_query && grown_cfg.layout_path);
    assert_eq!(
        grown.count(),
        lp.count() + cfg.key_dim + 4 * cfg.lstm_hidden * 49 * cfg.conv_channels
    );
    let (obs, tokens) = first_views(&babyai("BabyAI-UnlockLocal-v0"), 8);
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    let tb = TokenBatch::new(&missions).unwrap();
    let codes = CellCodes::new(&obs);
    let mem = Memory::zeros(obs.len(), cfg.lstm_hidden).unwrap();
    let out = |cfg: ModelConfig, p: &Params| -> (Vec<f32>, Tensor) {
        let net = Net::new(cfg, p.detached()).unwrap();
        let (logits, _, _, vis) = net
            .step(&codes, &net.mission_inputs(&tb).unwrap(), &mem)
            .unwrap();
        (logits.flatten_all().unwrap().to_vec1().unwrap(), vis.x)
    };
    let before = out(lp_cfg, &lp).0;
    let after = out(grown_cfg, &grown).0;
    for (a, b) in before.iter().zip(&after) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
    // With the option, each of the two filtered copies keeps the view's norm.
    let normed = ModelConfig {
        filter_norm: true,
        ..grown_cfg
    };
    let x = out(normed, &grown).1;
    let filter = 49 * cfg.conv_channels;
    let o = Net::new(normed, grown.detached())
        .unwrap()
        .cells(&codes)
        .unwrap();
    let o_norms = row_norms(&o);
    for start in [0, filter] {
        let part = x.narrow(1, start, filter).unwrap();
        for (got, want) in row_norms(&part).iter().zip(&o_norms) {
            assert!(
                (got - want).abs() <= 1e-3 * want.max(1.0),
                "{got} vs {want}"
            );
        }
    }
}

/// `bundled:babyai` (since 2026-12-02 the filter norm study's choice, once
/// `bundled:babyai-grounded2`) grounds what the studies measured its parents miss: `M` on
/// GoToLocal and PickupLoc, the door word on GoToDoor, the location word on OpenDoorLoc
/// (held out: `M` `acc` 0.72, door 0.96, location 0.86; its parents' 0.17, 0.44 and 0.05 are in
/// experiments/study_filter_norm/), and it still reaches GoToLocal's targets (0.97 held out).
/// Validation seeds, as the study chose it on.
#[test]
fn the_bundled_babyai_agent_grounds_m_doors_and_locations() {
    let agent = groundscope::policy::bundled::BABYAI;
    let eval = Eval::validation(
        &[agent],
        "BabyAI-GoToLocal-v0,BabyAI-GoToDoor-v0,BabyAI-PickupLoc-v0,BabyAI-OpenDoorLoc-v0",
    );
    let at_least = |level: &str, word: &str, column: &str, floor: f64| {
        let value = eval.accuracy(agent, level, word, column);
        assert!(
            value >= floor,
            "{word} {column} on {level}: {value} < {floor}"
        );
    };
    for level in ["BabyAI-GoToLocal-v0", "BabyAI-PickupLoc-v0"] {
        at_least(level, "combined", "acc_mean", 0.6);
    }
    at_least("BabyAI-GoToLocal-v0", "object", "acc_mean", 0.6);
    at_least("BabyAI-GoToDoor-v0", "door", "acc_mean", 0.8);
    at_least("BabyAI-GoToDoor-v0", "door", "pointing_mean", 0.8);
    at_least("BabyAI-OpenDoorLoc-v0", "location", "acc_mean", 0.6);
    let success = eval.success(agent, "BabyAI-GoToLocal-v0");
    assert!(success >= 0.85, "GoToLocal success {success}");
}
