//! Fuzz tests: mutated checkpoints (JSON and safetensors), snapshots and training run states
//! must give a clean error or a valid result, never a panic. Mutations replace one JSON value
//! (numbers at the edges of their types, wrong types, empty or huge arrays) or flip bytes, so
//! they reach the validation behind the parser. Bounded to a few hundred cases each.

use std::path::Path;

use groundscope::env::{LevelConfig, Snapshot, TaskSet, verify_dump};
use groundscope::policy::checkpoint::weights_bytes;
use groundscope::policy::ppo::{PpoConfig, Trainer};
use groundscope::policy::{Checkpoint, ModelConfig, Params, TrainingState, Variant};
use proptest::prelude::*;
use serde_json::Value;
use sha2::Digest as _;

fn level() -> LevelConfig {
    LevelConfig {
        room_size: 6,
        n_objects: 2,
        tasks: TaskSet::Both,
        done_required: true,
        color_optional: true,
        babyai: None,
    }
}

fn small_model() -> ModelConfig {
    ModelConfig {
        lstm_hidden: 8,
        gru_hidden: 8,
        head_hidden: 8,
        ..ModelConfig::new(Variant::Attention)
    }
}

/// Every leaf of a JSON value, as a path of keys and indices.
fn leaves(v: &Value, path: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                path.push(Value::String(k.clone()));
                leaves(x, path, out);
                path.pop();
            }
        }
        Value::Array(a) if !a.is_empty() => {
            // Arrays count as leaves too (to be replaced whole), then their elements.
            out.push(path.clone());
            for (i, x) in a.iter().enumerate().take(16) {
                path.push(Value::from(i));
                leaves(x, path, out);
                path.pop();
            }
        }
        _ => out.push(path.clone()),
    }
}

fn at<'a>(v: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(v, |v, k| match k {
        Value::String(s) => &mut v[s.as_str()],
        Value::Number(n) => &mut v[n.as_u64().unwrap() as usize],
        _ => unreachable!(),
    })
}

/// Values a hostile or corrupted file may hold.
fn replacement(k: u8) -> Value {
    match k % 16 {
        0 => Value::from(0),
        1 => Value::from(-1),
        2 => Value::from(1u64 << 40),
        3 => Value::from(u64::MAX),
        4 => Value::from(1e300),
        5 => Value::from(0.5),
        6 => Value::Null,
        7 => Value::from("x"),
        8 => Value::Array(Vec::new()),
        9 => Value::Array(vec![Value::from(999); 3]),
        10 => Value::Object(serde_json::Map::new()),
        11 => Value::from(true),
        12 => Value::from(100),
        13 => Value::from(7),
        14 => Value::from(100_000),
        _ => Value::from(-1e9),
    }
}

/// `text` with up to three of its JSON values replaced. Integers too large for a JSON value
/// (the RNG states are u128) are carried through as placeholders.
fn mutate_json(text: &str, edits: &[(usize, u8)]) -> String {
    let (text, big) = hide_big_integers(text);
    let mut v: Value = serde_json::from_str(&text).unwrap();
    for &(i, k) in edits {
        let mut paths = Vec::new();
        leaves(&v, &mut Vec::new(), &mut paths);
        if paths.is_empty() {
            break;
        }
        let p = &paths[i % paths.len()];
        *at(&mut v, p) = replacement(k);
    }
    let mut out = serde_json::to_string(&v).unwrap();
    for (i, digits) in big.iter().enumerate() {
        out = out.replace(&format!("\"__big{i}__\""), digits);
    }
    out
}

/// Replaces every integer literal of more than 18 digits by a string placeholder.
fn hide_big_integers(text: &str) -> (String, Vec<String>) {
    let (mut out, mut big, mut run) = (String::new(), Vec::new(), String::new());
    let mut in_string = false;
    for ch in text.chars() {
        if !in_string && ch.is_ascii_digit() {
            run.push(ch);
            continue;
        }
        if !run.is_empty() {
            if run.len() > 18 {
                out += "\"__big";
                out += &big.len().to_string();
                out += "__\"";
                big.push(std::mem::take(&mut run));
            } else {
                out.push_str(&std::mem::take(&mut run));
            }
        }
        if ch == '"' {
            in_string = !in_string;
        }
        out.push(ch);
    }
    out.push_str(&run);
    (out, big)
}

fn checkpoint_parts() -> (String, Vec<u8>) {
    let model = small_model();
    let mut ckpt = Checkpoint::new(
        model,
        level(),
        TrainingState::default(),
        Params::init(&model, 3).unwrap(),
    );
    let dir = tempfile::tempdir().unwrap();
    ckpt.save(&dir.path().join("m")).unwrap();
    (
        std::fs::read_to_string(dir.path().join("m.json")).unwrap(),
        std::fs::read(dir.path().join("m.safetensors")).unwrap(),
    )
}

fn hex(bytes: &[u8]) -> String {
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_checkpoint_json_never_panics(edits in prop::collection::vec((any::<usize>(), any::<u8>()), 1..4)) {
        let (json, weights) = checkpoint_parts_cached();
        let text = mutate_json(json, &edits);
        if let Ok(ckpt) = Checkpoint::from_parts(&text, weights, Path::new("m.json"), Path::new("m.safetensors")) {
            // Whatever loads must be a usable network.
            prop_assert!(ckpt.meta.model.validate().is_ok());
            prop_assert_eq!(weights_bytes(&ckpt.params).unwrap().len(), weights.len());
        }
    }

    #[test]
    fn mutated_safetensors_never_panic(flips in prop::collection::vec((any::<usize>(), any::<u8>()), 1..8), cut in any::<Option<usize>>()) {
        let (json, weights) = checkpoint_parts_cached();
        let mut bytes = weights.clone();
        for (i, b) in flips {
            // Mostly the header, where lengths and offsets live.
            let i = if b % 2 == 0 { i % 200.min(bytes.len()) } else { i % bytes.len() };
            bytes[i] ^= b | 1;
        }
        if let Some(c) = cut {
            bytes.truncate(c % (bytes.len() + 1));
        }
        // With the hash updated, the loader must get past it to the tensors themselves.
        let mut meta: Value = serde_json::from_str(json).unwrap();
        meta["weights_sha256"] = Value::from(hex(&bytes));
        let _ = Checkpoint::from_parts(&meta.to_string(), &bytes, Path::new("m.json"), Path::new("m.safetensors"));
    }

    #[test]
    fn mutated_snapshots_never_panic(seed in 0u64..50, edits in prop::collection::vec((any::<usize>(), any::<u8>()), 1..4)) {
        let world = level().generate(seed).unwrap();
        let text = Snapshot::from_world(&world, None, Some(seed)).to_json();
        let text = mutate_json(&text, &edits);
        if let Ok(snap) = Snapshot::from_json(&text)
            && let Ok(mut w) = snap.to_world()
        {
            let _ = verify_dump(&snap);
            let _ = w.observe();
            for a in 0..7 {
                let action = groundscope::env::Action::from_index(a).unwrap();
                if w.ended() { break; }
                let _ = w.step(action);
            }
        }
    }

    #[test]
    fn mutated_run_states_never_panic(edits in prop::collection::vec((any::<usize>(), any::<u8>()), 1..4)) {
        let (mut trainer, state) = trainer_and_state();
        let text = mutate_json(&state, &edits);
        if trainer.restore_state(&text).is_ok() {
            // A state that was accepted must train: restoring is where a bad state is refused.
            let update = trainer.update();
            prop_assert!(update.is_ok(), "an accepted run state fails to train: {:?}", update.err());
        }
    }
}

fn checkpoint_parts_cached() -> &'static (String, Vec<u8>) {
    static PARTS: std::sync::OnceLock<(String, Vec<u8>)> = std::sync::OnceLock::new();
    PARTS.get_or_init(checkpoint_parts)
}

fn ppo() -> PpoConfig {
    PpoConfig {
        procs: 2,
        frames_per_proc: 4,
        batch_size: 4,
        ..PpoConfig::default()
    }
}

/// A trainer after one update, and its run state.
fn trainer_and_state() -> (Trainer, String) {
    static STATE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    let make = || {
        let model = small_model();
        Trainer::new(model, level(), ppo(), Params::init(&model, 1).unwrap(), 1).unwrap()
    };
    let state = STATE.get_or_init(|| {
        let mut t = make();
        t.update().unwrap();
        t.state_json().unwrap()
    });
    (make(), state.clone())
}

#[test]
fn run_state_fields_are_checked_by_name() {
    let (mut trainer, state) = trainer_and_state();
    // The unmutated state round-trips through the mutator's placeholders.
    trainer.restore_state(&mutate_json(&state, &[])).unwrap();
    let (text, big) = hide_big_integers(&state);
    assert!(!big.is_empty());
    let state_value = |edit: &dyn Fn(&mut Value)| -> String {
        let mut v: Value = serde_json::from_str(&text).unwrap();
        edit(&mut v);
        let mut out = v.to_string();
        for (i, digits) in big.iter().enumerate() {
            out = out.replace(&format!("\"__big{i}__\""), digits);
        }
        out
    };
    for (edit, field) in [
        (
            &(|v: &mut Value| v["envs"][0]["world"]["agent_dir"] = Value::from(9))
                as &dyn Fn(&mut Value),
            "agent_dir",
        ),
        (
            &|v: &mut Value| v["envs"][1]["tokens"] = Value::from(vec![999]),
            "envs[1].tokens",
        ),
        (
            &|v: &mut Value| v["envs"][0]["world"]["max_steps"] = Value::from(0),
            "max_steps",
        ),
        (
            &|v: &mut Value| v["envs"][0]["h"] = Value::from(vec![0.5]),
            "envs[0].h",
        ),
    ] {
        let err = trainer
            .restore_state(&state_value(edit))
            .unwrap_err()
            .to_string();
        assert!(err.contains(field), "{field}: {err}");
    }
}

#[test]
fn zero_or_huge_model_sizes_are_refused_by_name() {
    let (json, weights) = checkpoint_parts_cached();
    for (field, v) in [("key_dim", 0u64), ("lstm_hidden", 100_000)] {
        let mut meta: Value = serde_json::from_str(json).unwrap();
        meta["model"][field] = Value::from(v);
        let err = Checkpoint::from_parts(
            &meta.to_string(),
            weights,
            Path::new("m.json"),
            Path::new("m.safetensors"),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains(field), "{err}");
    }
}
