//! `groundscope study` with its runs' steps as typed data (#80): what the manifest holds, and a
//! plan written before the steps were typed (its steps command lines), which is converted once
//! by the command line's own parser and runs as it did.

use crate::common::{assert_bad_input, gs, stderr, stdout};
use crate::study::{plan, read, spec};

use std::path::Path;

use sha2::{Digest as _, Sha256};

/// The steps of run `recipe-small-s1` of `spec("[1]", false)` as the earlier version's plan
/// wrote them: `train`'s and `eval`'s arguments.
fn old_steps(recipe: &str) -> (Vec<String>, Vec<String>) {
    let hidden = if recipe == "tiny" { "16" } else { "8" };
    let dir = format!("runs/{recipe}-small-s1");
    let train = [
        "--procs",
        "4",
        "--frames-per-proc",
        "16",
        "--batch-size",
        "32",
        "--hidden",
        hidden,
        "--eval-interval",
        "0",
        "--size",
        "5",
        "--objects",
        "1",
        "--tasks",
        "goto",
        "--no-done",
        "--seed",
        "1",
        "--frames",
        "128",
        "--out",
        dir.as_str(),
        "--quiet",
    ];
    let eval_out = format!("{dir}/eval");
    let eval = [
        "--checkpoint",
        dir.as_str(),
        "--sizes",
        "5",
        "--objects",
        "1",
        "--seeds",
        "1",
        "--episodes",
        "4",
        "--out",
        eval_out.as_str(),
        "--quiet",
    ];
    let owned = |a: &[&str]| -> Vec<String> { a.iter().copied().map(str::to_owned).collect() };
    (owned(&train), owned(&eval))
}

/// The hash the earlier version gave a run: its name, then each step's command and arguments.
fn old_hash(name: &str, steps: &[(&str, &[String])]) -> String {
    let mut h = Sha256::new();
    h.update(name.as_bytes());
    for (cmd, args) in steps {
        h.update([0]);
        h.update(cmd.as_bytes());
        for a in *args {
            h.update([1]);
            h.update(a.as_bytes());
        }
    }
    format!("{:x}", h.finalize())
}

/// The manifest the earlier version wrote for `study` (planned from `spec("[1]", false)` by
/// this one, whose binary it names), `edit` applied to each run's `train` arguments before
/// they are hashed.
fn old_manifest(study: &Path, edit: impl Fn(&mut Vec<String>)) -> String {
    let typed: serde_json::Value =
        serde_json::from_str(&read(&study.join("manifest.json"))).unwrap();
    let runs: Vec<serde_json::Value> = ["other", "tiny"]
        .iter()
        .map(|recipe| {
            let name = format!("{recipe}-small-s1");
            let (mut train, eval) = old_steps(recipe);
            edit(&mut train);
            let hash = old_hash(
                &name,
                &[("train", train.as_slice()), ("eval", eval.as_slice())],
            );
            serde_json::json!({"name": name, "recipe": recipe, "levels": "small", "seed": 1,
                "train": train, "eval": eval, "threads": 1, "hash": hash})
        })
        .collect();
    serde_json::to_string_pretty(&serde_json::json!({"format": "groundscope-study",
        "name": typed["name"], "binary": typed["binary"], "runs": runs}))
    .unwrap()
}

#[test]
fn a_manifest_holds_each_runs_steps_as_typed_data() {
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let m: serde_json::Value =
        serde_json::from_str(&read(&dir.path().join("study/manifest.json"))).unwrap();
    assert_eq!(m["version"], 2);
    let run = &m["runs"][1];
    assert_eq!(run["name"], "tiny-small-s1");
    // No flag is left in it: the training's settings by their names, the evaluation's sweep.
    assert_eq!(run["train"]["model"]["lstm_hidden"], 16);
    assert_eq!(run["train"]["ppo"]["procs"], 4);
    assert_eq!(run["train"]["frames"], 128);
    assert_eq!(run["train"]["levels"][0]["level"]["room_size"], 5);
    assert_eq!(run["eval"]["sweep"]["sizes"], serde_json::json!([5]));
    assert_eq!(run["eval"]["sweep"]["episodes"], 4);
    assert!(!read(&dir.path().join("study/manifest.json")).contains("\"--"));
}

#[test]
fn a_plan_of_command_lines_is_converted_once_and_runs_as_planned() {
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    let typed = read(&study.join("manifest.json"));
    let old = old_manifest(&study, |_| {});
    // Planned again over the old manifest, the same spec changes no run (the old steps mean
    // what the new ones do).
    std::fs::write(study.join("manifest.json"), &old).unwrap();
    let o = plan(dir.path(), &spec("[1]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(read(&study.join("manifest.json")), typed);
    // Run from the old manifest: converted once into the manifest this version plans, byte
    // for byte, and the run trains, evaluates and is done.
    std::fs::write(study.join("manifest.json"), &old).unwrap();
    let o = gs(&["study", "exec", s, "tiny-small-s1"]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(
        stderr(&o).contains("converted into typed steps"),
        "{}",
        stderr(&o)
    );
    assert_eq!(read(&study.join("manifest.json")), typed);
    assert!(study.join("runs/tiny-small-s1/study-done.json").is_file());
    let o = gs(&["study", "exec", s, "tiny-small-s1"]);
    assert_eq!(stdout(&o).trim(), "tiny-small-s1: done");
    assert!(!stderr(&o).contains("converted"), "{}", stderr(&o));
}

#[test]
fn an_old_plan_edited_by_hand_or_no_longer_parsed_is_refused_naming_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    let manifest = study.join("manifest.json");
    // A step edited after the plan: it no longer hashes to its hash.
    let mut edited: serde_json::Value =
        serde_json::from_str(&old_manifest(&study, |_| {})).unwrap();
    edited["runs"][1]["train"][1] = "8".into();
    std::fs::write(&manifest, edited.to_string()).unwrap();
    let o = gs(&["study", "run", s, "--quiet"]);
    assert_bad_input(&o, "run tiny-small-s1: its steps do not hash");
    // A flag this version does not have (hashed as the old plan would): named with the run,
    // and the way out.
    let gone = old_manifest(&study, |train| train.push("--no-such-flag".into()));
    std::fs::write(&manifest, &gone).unwrap();
    let o = gs(&["study", "exec", s, "tiny-small-s1"]);
    assert_bad_input(
        &o,
        "run other-small-s1, planned by an earlier groundscope: train: ",
    );
    assert!(
        stderr(&o).contains("--no-such-flag") && stderr(&o).contains("plan the study again"),
        "{}",
        stderr(&o)
    );
    // Neither is rewritten, and no run was started.
    assert_eq!(read(&manifest), gone);
    assert!(!study.join("runs").exists());
}

#[test]
fn the_paper_recipe_study_planned_with_command_lines_reads_as_typed_steps() {
    // experiments/study_paper_recipe's manifest.json, as that study's plan wrote it.
    let old = read(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/study_paper_recipe/manifest.json"),
    );
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("study");
    std::fs::create_dir(&study).unwrap();
    std::fs::write(study.join("manifest.json"), &old).unwrap();
    let o = gs(&["study", "collect", study.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("collected 0 finished runs of 6"),
        "{}",
        stdout(&o)
    );
    assert!(
        stderr(&o).contains("converted into typed steps"),
        "{}",
        stderr(&o)
    );
    let old: serde_json::Value = serde_json::from_str(&old).unwrap();
    let new: serde_json::Value = serde_json::from_str(&read(&study.join("manifest.json"))).unwrap();
    assert_eq!(new["version"], 2);
    let names = |m: &serde_json::Value| -> Vec<serde_json::Value> {
        m["runs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["name"].clone())
            .collect()
    };
    assert_eq!(names(&new), names(&old));
    // Its first run's flags, as what they mean.
    let run = &new["runs"][0];
    assert_eq!(run["train"]["model"]["conv_kernel"], 1);
    assert_eq!(run["train"]["model"]["attend_words"], "content");
    assert_eq!(run["train"]["ppo"]["lr"], 0.0003);
    assert_eq!(run["train"]["tracking"]["eval_episodes"], 100);
    assert_eq!(run["eval"]["sweep"]["first_seed"], 1500);
    assert_eq!(run["threads"], 1);
}
