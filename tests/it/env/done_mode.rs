//! A registered level id means `gym.make(id)` on every command: no `done` action unless
//! `--done`; the paper's level keeps `done` unless `--no-done`; the mode is named in traces,
//! reports and the replay commands a report gives.

use crate::common::{gs, stderr, stdout};
use serde_json::Value;

fn trace_level(args: &[&str]) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.json");
    let mut all = vec!["replay", "--checkpoint", "bot"];
    all.extend_from_slice(args);
    all.extend(["--trace", path.to_str().unwrap()]);
    let o = gs(&all);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    let t: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    t["level"].clone()
}

#[test]
fn a_registered_id_runs_without_done_and_done_is_one_switch() {
    let id = "BabyAI-GoToLocal-v0";
    assert_eq!(trace_level(&["--level", id])["done_required"], false);
    assert_eq!(
        trace_level(&["--level", id, "--done"])["done_required"],
        true
    );
    // The plural spelling is accepted for the one level.
    assert_eq!(trace_level(&["--levels", id])["done_required"], false);
    // The paper's level keeps done; --no-done turns it off.
    assert_eq!(trace_level(&[])["done_required"], true);
    assert_eq!(trace_level(&["--no-done"])["done_required"], false);
    let o = gs(&["replay", "--level", id, "--done", "--no-done"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));

    // env show and bench env follow the same rule.
    let o = gs(&[
        "bench", "env", "--level", id, "--steps", "100", "--resets", "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let line: Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(line["level"], id);
    let o = gs(&[
        "bench", "env", "--level", id, "--done", "--steps", "100", "--resets", "2",
    ]);
    let line: Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(line["level"], format!("{id} (done-action mode)"));
}

/// In the registered mode the bot succeeds at a go-to mission as minigrid's does (facing the
/// target); `eval --done` names the mode in report.md and in every replay command it gives.
#[test]
fn eval_names_the_done_action_mode() {
    let dir = tempfile::tempdir().unwrap();
    for (flag, out) in [(None, "reg"), (Some("--done"), "done")] {
        let path = dir.path().join(out);
        let mut args = vec![
            "eval",
            "--checkpoint",
            "bundled:attention",
            "--level",
            "BabyAI-GoTo-v0",
            "--seeds",
            "1",
            "--episodes",
            "6",
            "--quiet",
            "--out",
            path.to_str().unwrap(),
        ];
        args.extend(flag);
        let o = gs(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let md = std::fs::read_to_string(path.join("report.md")).unwrap();
        let named = md.contains("BabyAI-GoTo-v0 (done-action mode)");
        assert_eq!(named, flag.is_some(), "{md}");
        let failures: Value =
            serde_json::from_str(&std::fs::read_to_string(path.join("failures.json")).unwrap())
                .unwrap();
        let list = failures.as_array().unwrap();
        assert!(
            !list.is_empty(),
            "the bundled model fails some GoTo episodes"
        );
        for f in list {
            let replay = f["replay"].as_str().unwrap();
            assert_eq!(replay.contains(" --done"), flag.is_some(), "{replay}");
            assert_eq!(f["done_required"], flag.is_some());
        }
    }
}
