//! `train --ground-loss λ` (issue #64): the maps it supervises are the maps the tools show, it
//! moves them onto what the words name, it is named in the checkpoint, and bad values are one
//! line naming the flag.

use crate::common::{self, assert_bad_input, gs, stderr};
use candle_core::{Device, Tensor};
use groundscope::env::targets::{pending_targets, word_targets};
use groundscope::env::view::Observation;
use groundscope::env::{LevelConfig, LevelId, World};
use groundscope::policy::obs::{CellCodes, TokenBatch};
use groundscope::policy::ppo::{PpoConfig, Trainer};
use groundscope::policy::{Memory, ModelConfig, Net, Params, Variant};

/// The first views and tokens of `count` episodes of `level` from seed `first`, with their worlds.
fn episodes(
    level: &LevelConfig,
    first: u64,
    count: u64,
) -> (Vec<World>, Vec<Observation>, Vec<Vec<u32>>) {
    let worlds: Vec<World> = (first..first + count)
        .map(|s| level.generate(s).unwrap())
        .collect();
    let obs = worlds.iter().map(World::observe).collect();
    let tokens = worlds
        .iter()
        .map(|w| groundscope::env::vocab::tokenize(&w.mission).unwrap())
        .collect();
    (worlds, obs, tokens)
}

fn values(t: &Tensor) -> Vec<f32> {
    t.flatten_all().unwrap().to_vec1().unwrap()
}

#[test]
fn the_supervised_maps_are_the_maps_the_tools_show() {
    // The training path's maps (composite ops on the fused path's inputs) against the acting
    // path's traced ones, for the paper's model and the key variants of the big-room study.
    let split = ModelConfig {
        key_kernel: Some(1),
        ..ModelConfig::new(Variant::Attention)
    };
    let variants = [
        ModelConfig::new(Variant::Attention),
        split,
        ModelConfig {
            null_key: true,
            ..ModelConfig::new(Variant::Attention)
        },
        ModelConfig {
            null_key: true,
            ..split
        },
        ModelConfig {
            key_context: true,
            attend_words: groundscope::policy::AttendWords::Content,
            ..split
        },
    ];
    let level = LevelConfig::babyai(LevelId::parse("BabyAI-PutNextLocal-v0").unwrap(), false);
    let (_, obs, tokens) = episodes(&level, 0, 6);
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    for cfg in variants {
        let cfg = ModelConfig {
            vocab_size: ModelConfig::vocab_size_for(&level),
            ..cfg
        };
        let net = Net::new(cfg, Params::init(&cfg, 4).unwrap().detached()).unwrap();
        let tb = TokenBatch::new(&missions).unwrap();
        let n = obs.len();
        let keep = Tensor::ones((1, n), candle_core::DType::F32, &Device::Cpu).unwrap();
        let mem = Memory::zeros(n, cfg.lstm_hidden).unwrap();
        let out = net
            .sequence_with_maps(&CellCodes::new(&obs), &tb, &mem, &keep, true)
            .unwrap();
        let (a, m) = out.maps.expect("an attention model gives maps");
        let mi = net.mission_inputs(&tb).unwrap();
        let (_, _, _, vis) = net.step(&CellCodes::new(&obs), &mi, &mem).unwrap();
        let att = vis.attention.unwrap();
        for (got, want, what) in [(&a, &att.a, "word maps"), (&m, &att.m, "M")] {
            assert_eq!(got.dims(), want.dims(), "{what}: {cfg:?}");
            for (x, y) in values(got).iter().zip(values(want)) {
                assert!((x - y).abs() < 1e-5, "{what}: {x} vs {y} ({cfg:?})");
            }
        }
    }
    // A baseline has no maps to give.
    let base = ModelConfig::new(Variant::Baseline);
    let net = Net::new(base, Params::init(&base, 4).unwrap().detached()).unwrap();
    let paper = LevelConfig::default();
    let (_, obs, tokens) = episodes(&paper, 0, 2);
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    let keep = Tensor::ones((1, 2), candle_core::DType::F32, &Device::Cpu).unwrap();
    let out = net
        .sequence_with_maps(
            &CellCodes::new(&obs),
            &TokenBatch::new(&missions).unwrap(),
            &Memory::zeros(2, base.lstm_hidden).unwrap(),
            &keep,
            true,
        )
        .unwrap();
    assert!(out.maps.is_none());
}

/// Mean relevance mass, over `episodes`' first views, of each scored word's map on what it
/// names and of `M` on the waited clause's targets, under `params`.
fn mean_masses(cfg: ModelConfig, params: &Params, level: &LevelConfig) -> (f64, f64) {
    let (worlds, obs, tokens) = episodes(level, 7_000, 48);
    let net = Net::new(cfg, params.detached()).unwrap();
    let missions: Vec<&[u32]> = tokens.iter().map(Vec::as_slice).collect();
    let mi = net
        .mission_inputs(&TokenBatch::new(&missions).unwrap())
        .unwrap();
    let mem = Memory::zeros(obs.len(), cfg.lstm_hidden).unwrap();
    let (_, _, _, vis) = net.step(&CellCodes::new(&obs), &mi, &mem).unwrap();
    let att = vis.attention.unwrap();
    let (a, m) = (
        att.a.to_vec3::<f32>().unwrap(),
        att.m.to_vec2::<f32>().unwrap(),
    );
    let mass = |row: &[f32], cells: &[(usize, usize)]| -> f64 {
        cells.iter().map(|&(x, y)| f64::from(row[y * 7 + x])).sum()
    };
    let (mut words, mut nw, mut comb, mut nm) = (0.0, 0.0, 0.0, 0.0);
    for (b, w) in worlds.iter().enumerate() {
        for t in word_targets(w, &obs[b], tokens[b].len()) {
            if !t.cells.is_empty() {
                words += mass(&a[b][t.word], &t.cells);
                nw += 1.0;
            }
        }
        let p = pending_targets(w, &obs[b]);
        if !p.is_empty() {
            comb += mass(&m[b], &p);
            nm += 1.0;
        }
    }
    assert!(nw > 10.0 && nm > 10.0, "too few scored views: {nw} {nm}");
    (words / nw, comb / nm)
}

#[test]
fn the_loss_moves_the_maps_onto_what_the_words_name_and_none_without_it() {
    // A fresh BabyAI network on GoToDoor, whose maps do not know the door: a few updates of
    // cloning with a strong grounding loss raise the maps' mass on their objects well past a
    // control that clones alone from the same start.
    let (cfg, parent_params) = super::plain_babyai_parent();
    let level = LevelConfig::babyai(LevelId::parse("BabyAI-GoToDoor-v0").unwrap(), false);
    let before = mean_masses(cfg, &parent_params, &level);
    let after = |lambda: f64| {
        let ppo = PpoConfig {
            procs: 8,
            frames_per_proc: 32,
            batch_size: 64,
            imitate: true,
            lr: 3e-4,
            ground_loss: lambda,
            ..PpoConfig::default()
        };
        // A fresh copy: Adam updates the weights in place.
        let params = super::plain_babyai_parent().1;
        let mut t = Trainer::warm_start(cfg, level, ppo, params, 1, 0, 0).unwrap();
        let mut ground = Vec::new();
        for _ in 0..6 {
            ground.push(t.update().unwrap().ground_loss);
        }
        (mean_masses(cfg, &t.params, &level), ground)
    };
    let (supervised, terms) = after(5.0);
    let (control, control_terms) = after(0.0);
    assert!(control_terms.iter().all(|&g| g == 0.0), "{control_terms:?}");
    assert!(terms.iter().all(|&g| g > 0.0), "{terms:?}");
    assert!(terms.last() < terms.first(), "the term falls: {terms:?}");
    assert!(
        supervised.0 > before.0 + 0.1 && supervised.0 > control.0 + 0.1,
        "word maps' mass: before {before:?}, supervised {supervised:?}, control {control:?}"
    );
    assert!(
        supervised.1 > before.1 && supervised.1 > control.1,
        "M's mass: before {before:?}, supervised {supervised:?}, control {control:?}"
    );
}

#[test]
fn bad_weights_and_baselines_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let out = out.to_str().unwrap();
    for bad in ["-1", "nan", "101", "inf"] {
        let o = gs(&[
            "train",
            "--frames",
            "2048",
            "--out",
            out,
            "--ground-loss",
            bad,
            "--quiet",
        ]);
        assert_bad_input(&o, "--ground-loss");
        assert!(!dir.path().join("run").exists(), "{bad}: left {out}");
    }
    let o = gs(&[
        "train",
        "--model",
        "baseline",
        "--frames",
        "2048",
        "--out",
        out,
        "--ground-loss",
        "1",
        "--quiet",
    ]);
    assert_bad_input(&o, "--ground-loss");
    assert!(stderr(&o).contains("baseline"), "{}", stderr(&o));
    assert!(!dir.path().join("run").exists());
}

#[test]
fn the_checkpoint_names_the_supervision_and_its_children_keep_it() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("sup");
    let child = dir.path().join("child");
    let plain = dir.path().join("plain");
    let (run_s, child_s, plain_s) = (
        run.to_str().unwrap(),
        child.to_str().unwrap(),
        plain.to_str().unwrap(),
    );
    // The small run of the round-5 tests (64-frame updates on a 5×5 room).
    let train = |dir: &str, frames: &str, extra: &[&str]| {
        let args = common::small_run(dir, frames, extra);
        let o = gs(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    };
    let meta = |dir: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join("model.json")).unwrap()).unwrap()
    };
    train(run_s, "64", &["--ground-loss", "0.5"]);
    assert_eq!(meta(&run)["training"]["ground_loss"], 0.5);
    // A resume keeps λ; one that gives another is refused naming the flag.
    train(run_s, "128", &["--resume"]);
    assert_eq!(meta(&run)["training"]["ground_loss"], 0.5);
    let o = gs(&[
        "train",
        "--out",
        run_s,
        "--frames",
        "192",
        "--resume",
        "--ground-loss",
        "2",
        "--quiet",
    ]);
    assert_bad_input(&o, "--ground-loss");
    // A child started from it without the loss still says its maps were supervised.
    train(child_s, "192", &["--init", run_s]);
    assert_eq!(meta(&child)["training"]["ground_loss"], 0.5);
    // Without the loss the field is absent, as in every checkpoint before it.
    train(plain_s, "64", &[]);
    assert!(meta(&plain)["training"].get("ground_loss").is_none());
    // An evaluation's report says which maps were supervised, and how bundled:babyai was
    // trained (its metadata names only the first of its sixteen levels).
    let report = dir.path().join("report");
    let o = gs(&[
        "eval",
        "--checkpoint",
        child_s,
        "--checkpoint",
        plain_s,
        "--checkpoint",
        "bundled:babyai",
        "--levels",
        "BabyAI-GoToLocal-v0",
        "--seeds",
        "1",
        "--episodes",
        "2",
        "--out",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    let line = |name: &str| {
        md.lines()
            .find(|l| l.starts_with(&format!("- `{name}`")))
            .unwrap_or_else(|| panic!("no line for {name}:\n{md}"))
            .to_owned()
    };
    assert!(
        line(child_s).contains("supervised by `--ground-loss 0.5`"),
        "{md}"
    );
    assert!(!line(plain_s).contains("supervised"), "{md}");
    let babyai = line("bundled:babyai");
    assert!(
        babyai.contains("imitation of minigrid's BabyAI bot on sixteen BabyAI levels")
            && !babyai.contains("trained on"),
        "{babyai}"
    );
}
