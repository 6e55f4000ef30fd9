//! The manifest's typed steps: what they hash, how they read back, and what a re-plan and an
//! earlier version's manifest get.

use serde_json::Value;

use super::*;
use crate::env::LevelConfig;
use crate::policy::ppo::PpoConfig;
use crate::policy::{ModelConfig, Variant};
use crate::run::Tracking;

fn recipe() -> RunRecipe {
    RunRecipe {
        model: ModelConfig::new(Variant::Attention),
        levels: LevelConfig::default().into(),
        ppo: PpoConfig::default(),
        seed: 1,
        frames: 1000,
        tracking: Tracking::default(),
        init: None,
        teachers: Vec::new(),
    }
}

fn eval() -> EvalSpec {
    EvalSpec {
        sweep: Sweep {
            sizes: vec![8],
            objects: vec![4],
            seeds: 1,
            first_seed: 0,
            episodes: 10,
            sample: false,
            levels: Vec::new(),
            done: None,
        },
        alpha: 0.5,
        saliency: false,
        top_k: 10,
        min_success: None,
        min_acc_ng: None,
        html: false,
        export_failures: false,
        jobs: None,
    }
}

fn named(name: &str, train: RunRecipe, eval: EvalSpec) -> PlannedRun {
    let steps = RunSteps {
        train,
        eval,
        faithfulness: None,
    };
    PlannedRun::new(name, "ppo", "paper", 1, steps).unwrap()
}

fn planned(train: RunRecipe, eval: EvalSpec) -> PlannedRun {
    named("ppo-paper-s1", train, eval)
}

/// `manifest` written into a new study directory as a plan writes it.
fn written(manifest: &Manifest) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("manifest.json"),
        manifest.to_json().unwrap(),
    )
    .unwrap();
    dir
}

#[test]
fn a_manifest_holds_typed_steps_whose_hash_changes_with_any_field() {
    let run = planned(recipe(), eval());
    // The same steps hash alike; a field changed anywhere in them changes the hash.
    assert_eq!(run.hash, planned(recipe(), eval()).hash);
    let mut lr = recipe();
    lr.ppo.lr *= 2.0;
    let mut episodes = eval();
    episodes.sweep.episodes = 11;
    let mut threads = recipe();
    threads.ppo.threads = 2;
    for other in [
        planned(lr, eval()),
        planned(recipe(), episodes),
        planned(threads, eval()),
    ] {
        assert_ne!(other.hash, run.hash);
    }
    assert_eq!(planned(recipe(), eval()).threads, 1);
    // The file holds the steps as data, and reads back as it was written, its hash intact.
    let m = Manifest::new("s", "groundscope", vec![run.clone()]);
    let dir = written(&m);
    let json: Value = serde_json::from_str(&m.to_json().unwrap()).unwrap();
    assert_eq!(json["version"], 2);
    assert_eq!(json["runs"][0]["eval"]["sweep"]["episodes"], 10);
    assert!(json["runs"][0]["train"]["ppo"]["lr"].is_number());
    let back = Manifest::read(dir.path()).unwrap();
    assert_eq!(back.runs[0].train, run.train);
    assert_eq!(back.runs[0].eval, run.eval);
    back.check_runs(&dir.path().join("manifest.json")).unwrap();
}

#[test]
fn an_edited_step_no_longer_hashes_and_is_refused_naming_the_run() {
    let m = Manifest::new("s", "groundscope", vec![planned(recipe(), eval())]);
    let dir = written(&m);
    let path = dir.path().join("manifest.json");
    let mut json: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    json["runs"][0]["train"]["seed"] = 7.into();
    std::fs::write(&path, json.to_string()).unwrap();
    let e = Manifest::read(dir.path())
        .unwrap()
        .check_runs(&path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("run ppo-paper-s1: its steps do not hash") && e.contains("plan the study again"),
        "{e}"
    );
    // A field the steps do not have is refused when the file is read, naming the file.
    json["runs"][0]["train"]["seed"] = 1.into();
    json["runs"][0]["eval"]["episodes"] = 3.into();
    std::fs::write(&path, json.to_string()).unwrap();
    let e = Manifest::read(dir.path()).unwrap_err().to_string();
    assert!(e.contains("manifest.json") && e.contains("episodes"), "{e}");
    assert!(!e.contains('\n'), "{e}");
}

#[test]
fn a_manifest_of_command_lines_is_handed_over_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let old = r#"{"format": "groundscope-study", "name": "s", "binary": "groundscope",
        "runs": [{"name": "a-b-s1", "recipe": "a", "levels": "b", "seed": 1,
                  "train": ["--seed", "1"], "eval": ["--episodes", "2"], "threads": 1,
                  "hash": "0"}]}"#;
    std::fs::write(dir.path().join("manifest.json"), old).unwrap();
    match Manifest::read_stored(dir.path()).unwrap() {
        Stored::CommandLines { path, text } => {
            assert_eq!(path, dir.path().join("manifest.json"));
            assert_eq!(text, old);
        }
        Stored::Typed(m) => panic!("read as typed: {m:?}"),
    }
    let e = Manifest::read(dir.path()).unwrap_err().to_string();
    assert!(
        e.contains("manifest.json") && e.contains("earlier groundscope"),
        "{e}"
    );
    // Neither a study manifest nor a later version is taken for one.
    for (text, says) in [
        (r#"{"format": "other"}"#, "format \"other\""),
        (
            r#"{"format": "groundscope-study", "version": 9}"#,
            "version \"9\"",
        ),
        ("[1, 2]", "no format"),
    ] {
        std::fs::write(dir.path().join("manifest.json"), text).unwrap();
        let e = Manifest::read_stored(dir.path()).unwrap_err().to_string();
        assert!(e.contains(says) && e.contains("manifest.json"), "{e}");
    }
}

#[test]
fn a_replan_may_add_runs_and_names_a_changed_or_dropped_one() {
    let run = planned(recipe(), eval());
    let m = Manifest::new("s", "g", vec![run.clone()]);
    let added = named("ppo-paper-s2", recipe(), eval());
    check_replan(
        &m,
        &Manifest::new("s", "g", vec![run.clone(), added.clone()]),
    )
    .unwrap();
    let mut episodes = eval();
    episodes.sweep.episodes = 20;
    let changed = Manifest::new("s", "g", vec![planned(recipe(), episodes)]);
    let e = check_replan(&m, &changed).unwrap_err().to_string();
    assert!(
        e.contains("changes run ppo-paper-s1") && e.contains("eval"),
        "{e}"
    );
    let e = check_replan(&m, &Manifest::new("s", "g", vec![added]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("drops run ppo-paper-s1"), "{e}");
}
