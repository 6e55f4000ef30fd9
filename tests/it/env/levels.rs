//! Transparency on every BabyAI level: `eval --levels` and its `episodes.csv`; a PyTorch-
//! trained agent's evaluation reproduced episode by episode against its own Python
//! evaluation in minigrid; models trained on BabyAI levels; what a checkpoint of fewer words
//! does with a new one.

use crate::common::{assert_bad_input, csv_rows, gs, onnx_fixture, stderr, stdout};

/// The agent of `export/make_python_agent.sh`: rl-starter-files' ACModel trained in PyTorch
/// on BabyAI-GoToRedBallGrey-v0, evaluated by groundscope and replayed by
/// `export/eval_in_python.py` in minigrid 3.2.0 with onnxruntime. The same 500 episodes:
/// missions, actions, success, steps and returns.
#[test]
fn a_python_trained_agent_gives_its_own_python_evaluation_episode_by_episode() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let graph = onnx_fixture("acmodel_gotoredballgrey.onnx");
    let o = gs(&[
        "eval",
        "--checkpoint",
        graph.to_str().unwrap(),
        "--levels",
        "BabyAI-GoToRedBallGrey-v0",
        "--seeds",
        "5",
        "--episodes",
        "100",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ours = csv_rows(&out.join("episodes.csv"));
    let python = csv_rows(&onnx_fixture("acmodel_gotoredballgrey_python.csv"));
    assert_eq!(ours.len(), 500);
    assert_eq!(python.len(), ours.len());
    for (a, b) in ours.iter().zip(&python) {
        for col in [
            "level",
            "eval_seed",
            "episode",
            "level_seed",
            "mission",
            "success",
            "steps",
            "actions",
        ] {
            assert_eq!(a[col], b[col], "{col} of episode {a:?}");
        }
        let (ra, rb): (f64, f64) = (a["return"].parse().unwrap(), b["return"].parse().unwrap());
        assert!((ra - rb).abs() < 1e-6, "return {ra} vs {rb}");
    }
    let wins = ours.iter().filter(|r| r["success"] == "1").count();
    assert!(
        wins > 400,
        "the agent succeeds in most episodes: {wins} of 500"
    );
    // Failures carry a class; successes none.
    assert!(
        ours.iter()
            .all(|r| (r["success"] == "1") == r["failure_class"].is_empty())
    );
    // The report names the level and the graph's own name.
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("## Per level"), "{md}");
    assert!(md.contains("| BabyAI-GoToRedBallGrey-v0 |"), "{md}");
    assert!(out.join("levels_success.png").exists());
    assert!(
        !out.join("fig6_success.png").exists(),
        "no paper figure without a paper cell"
    );
}

#[test]
fn a_sweep_over_levels_reports_each_level_and_word_class() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let o = gs(&[
        "eval",
        "--checkpoint",
        "bundled:attention",
        "--levels",
        "BabyAI-GoToLocal-v0,BabyAI-PickupLoc-v0",
        "--seeds",
        "2",
        "--episodes",
        "10",
        "--top-k",
        "3",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let eps = csv_rows(&out.join("episodes.csv"));
    assert_eq!(eps.len(), 2 * 2 * 10);
    assert_eq!(
        eps.iter()
            .filter(|r| r["level"] == "BabyAI-PickupLoc-v0")
            .count(),
        20
    );
    for r in &eps {
        let steps: usize = r["steps"].parse().unwrap();
        assert_eq!(r["actions"].split(' ').count(), steps, "{r:?}");
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let cells = report["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 2);
    assert_eq!(cells[1]["level"], "BabyAI-PickupLoc-v0");
    // PickupLoc's missions name locations: their words are scored, GoToLocal's have none.
    assert!(
        cells[1]["accuracy"]["location"]["evaluated_steps"]
            .as_u64()
            .unwrap()
            > 0
    );
    assert!(cells[0]["accuracy"].get("location").is_none());
    // Two levels of one room size are two rows of every table, not one shared row.
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    for id in ["BabyAI-GoToLocal-v0", "BabyAI-PickupLoc-v0"] {
        // Keyed by level, its grid and its rooms (not "size 8, objects 0").
        assert!(
            md.contains(&format!("| bundled:attention | {id} | 8×8 | 1×1 |")),
            "{md}"
        );
        // The failed episodes' exploration, one row per level.
        assert!(md.contains(&format!("| {id} | 8×8 | 1×1 |")), "{md}");
    }
    // Every CSV that names cells by size and objects names a BabyAI cell's level too.
    for csv in [
        "performance.csv",
        "accuracy.csv",
        "words.csv",
        "around.csv",
        "exploration.csv",
    ] {
        let rows = csv_rows(&out.join(csv));
        assert!(!rows.is_empty(), "{csv}");
        assert!(
            rows.iter().all(|r| r["level"].starts_with("BabyAI-")),
            "{csv}: {:?}",
            rows[0]
        );
    }
    // The worst episodes replay on their own level, and each level keeps its own list.
    let failures = std::fs::read_to_string(out.join("failures.json")).unwrap();
    if failures.contains("\"failed\"") {
        assert!(failures.contains("--level BabyAI-"), "{failures}");
    }
    let listed: Vec<serde_json::Value> = serde_json::from_str(&failures).unwrap();
    for (k, cell) in cells.iter().enumerate() {
        let failed = cell["failure_classes"]
            .as_object()
            .unwrap()
            .values()
            .map(|n| n.as_u64().unwrap())
            .sum::<u64>();
        let shown = listed
            .iter()
            .filter(|f| f["kind"] == "failed" && f["level"] == cell["level"])
            .count() as u64;
        assert_eq!(shown, failed.min(3), "cell {k}: {failures}");
        // Every failure has one behaviour count (none included).
        let behaviours = cell
            .get("behaviours")
            .and_then(|b| b.as_object())
            .map_or(0, |b| b.values().map(|n| n.as_u64().unwrap()).sum::<u64>());
        assert_eq!(behaviours, failed, "cell {k}");
    }
    assert!(!md.contains("| size | objects |"), "{md}");
    // The exploration figure has a row per level: as tall as the per-level success figure.
    let dims = |f: &str| image::image_dimensions(out.join(f)).unwrap();
    assert_eq!(dims("fig_exploration.png"), dims("levels_success.png"));
    // report.md defines every class it counts.
    for class in ["target_never_visible", "grounding", "wrong_object", "other"] {
        assert!(md.contains(&format!("- `{class}`: ")), "{md}");
    }
    // Twice the same level, or an unknown one, is refused before anything is written.
    let bad = dir.path().join("bad");
    for (levels, what) in [
        ("BabyAI-GoToLocal-v0,BabyAI-GoToLocal-v0", "listed twice"),
        ("BabyAI-GoToLocl-v0", "BabyAI-GoToLocal-v0"),
    ] {
        let o = gs(&[
            "eval",
            "--levels",
            levels,
            "--out",
            bad.to_str().unwrap(),
            "--quiet",
        ]);
        assert_bad_input(&o, what);
        assert!(!bad.exists());
    }
}

#[test]
fn a_checkpoint_of_the_papers_words_refuses_a_new_word_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let o = gs(&[
        "eval",
        "--checkpoint",
        "bundled:attention",
        "--levels",
        "BabyAI-GoToObjDoor-v0",
        "--seeds",
        "1",
        "--episodes",
        "5",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_bad_input(&o, "mission word \"door\" in mission");
    assert!(stderr(&o).contains("trained on"), "{}", stderr(&o));
    assert!(!out.exists());
}

/// `train --level` on a multi-room level and on a door level: the model gets all of BabyAI's
/// words, trains, and its own evaluation runs on its level.
#[test]
fn training_on_a_door_level_and_a_multi_room_level_works_end_to_end() {
    for level in ["BabyAI-GoToObjDoor-v0", "BabyAI-GoToObjMazeS4-v0"] {
        let dir = tempfile::tempdir().unwrap();
        let run = dir.path().join("run");
        let o = gs(&[
            "train",
            "--model",
            "attention",
            "--level",
            level,
            "--out",
            run.to_str().unwrap(),
            "--frames",
            "256",
            "--procs",
            "4",
            "--frames-per-proc",
            "32",
            "--batch-size",
            "64",
            "--hidden",
            "16",
            "--eval-interval",
            "0",
            "--quiet",
        ]);
        assert!(o.status.success(), "{level}: {}", stderr(&o));
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(run.join("model.json")).unwrap())
                .unwrap();
        assert_eq!(meta["level"]["babyai"], level);
        assert_eq!(meta["model"]["vocab_size"], 33, "all of BabyAI's words");
        assert!(
            meta["vocabulary"]
                .as_array()
                .unwrap()
                .iter()
                .any(|w| w == "door")
        );
        let report = dir.path().join("report");
        let o = gs(&[
            "eval",
            "--checkpoint",
            run.to_str().unwrap(),
            "--seeds",
            "1",
            "--episodes",
            "3",
            "--quiet",
            "--out",
            report.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{level}: {}", stderr(&o));
        let eps = csv_rows(&report.join("episodes.csv"));
        assert_eq!(eps.len(), 3);
        assert!(eps.iter().all(|r| r["level"] == level), "its own level");
    }
}

/// Faithfulness on a BabyAI level with an imported graph of few words: every part runs, and a
/// counterfactual whose edited mission names a word the graph never learnt is skipped with a
/// count, not an error.
#[test]
fn faithfulness_runs_on_a_level_and_skips_edits_the_model_cannot_read() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("faith");
    let graph = onnx_fixture("acmodel_gotoredballgrey.onnx");
    let o = gs(&[
        "faithfulness",
        "--checkpoint",
        graph.to_str().unwrap(),
        "--levels",
        "BabyAI-GoToRedBallGrey-v0",
        "--seeds",
        "1",
        "--episodes",
        "4",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(out.join("faithfulness.md")).unwrap();
    // "go to the red ball" recoloured names a colour this graph never saw.
    assert!(
        md.contains("counterfactual recolor_target (0 run, 4 skipped)"),
        "{md}"
    );
    assert!(
        md.contains("counterfactual swap_putnext (0 run, 4 skipped)"),
        "{md}"
    );
    assert!(
        md.contains("counterfactual move_target (4 run, 0 skipped)"),
        "{md}"
    );
    let json = std::fs::read_to_string(out.join("faithfulness.json")).unwrap();
    assert!(
        json.contains("\"level\": \"BabyAI-GoToRedBallGrey-v0\""),
        "{json}"
    );
}

/// `env list --checkpoint C` says which levels a checkpoint can read: the paper's pair reads
/// GoToLocal's missions and none of PutNextLocal's (naming the word), the bot reads all 96.
#[test]
fn env_list_says_which_levels_a_checkpoint_reads() {
    let o = gs(&["env", "list", "--checkpoint", "bundled:attention"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let row = |id: &str| {
        out.lines()
            .find(|l| l.starts_with(&format!("{id} ")))
            .unwrap_or_else(|| panic!("no row for {id}: {out}"))
            .to_owned()
    };
    assert!(row("BabyAI-GoToLocal-v0").ends_with("all 200"), "{out}");
    assert!(
        row("BabyAI-PutNextLocal-v0").ends_with("none (not \"put\")"),
        "{out}"
    );
    let o = gs(&["env", "list", "--checkpoint", "bot"]);
    assert!(
        stdout(&o).contains("the checkpoint reads every mission of 96 of them"),
        "{}",
        stdout(&o)
    );
}
