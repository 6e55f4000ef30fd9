//! Reliability, round 5 (issue #68), the command line's side: episodes' done mode, an
//! evaluation beside a training, the terminal summary, typos and refusals that guide. Each test
//! failed before its fix. (Split from `reliability::training`.)

use crate::common::{self, assert_bad_input, csv_rows, gs, small_run, stderr, stdout};

/// `episodes.csv` names the done mode of every row; `bench env` takes `--no-done` as the
/// docs say every command that runs a level does.
#[test]
fn episodes_record_their_done_mode_and_bench_env_takes_no_done() {
    let dir = tempfile::tempdir().unwrap();
    for (flag, want) in [("--done", "1"), ("--no-done", "0")] {
        let out = dir.path().join(flag);
        let o = gs(&[
            "eval",
            "--checkpoint",
            "bot",
            "--level",
            "BabyAI-GoToRedBall-v0",
            flag,
            "--seeds",
            "1",
            "--episodes",
            "3",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        for r in csv_rows(&out.join("episodes.csv")) {
            assert_eq!(r["done_required"], want, "{flag}: {r:?}");
        }
    }
    for flag in ["--no-done", "--done"] {
        let o = gs(&[
            "bench",
            "env",
            "--steps",
            "100",
            "--resets",
            "5",
            "--level",
            "BabyAI-GoToRedBall-v0",
            flag,
        ]);
        assert_eq!(o.status.code(), Some(0), "{flag}: {}", stderr(&o));
    }
}

/// An `eval --out D` beside a `train --out D`: each training save used to remove every hidden
/// `.groundscope-*` entry of the run directory, the evaluation's staged report among them, and
/// the evaluation then said "report in D" with no report. A save removes only its own stale
/// temporary files now; the evaluation's report arrives whole, every time.
#[test]
fn an_evaluation_into_a_training_directory_keeps_its_report() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let r = run.to_str().unwrap();
    std::fs::create_dir_all(&run).unwrap();
    // Another command's staging directory (in progress) and a temporary file left by a crash.
    let staging = run.join(".groundscope-staging-other");
    std::fs::create_dir_all(&staging).unwrap();
    std::fs::write(staging.join("report.md"), "x").unwrap();
    std::fs::write(run.join(".groundscope-old.tmp"), "x").unwrap();
    std::thread::sleep(std::time::Duration::from_millis(20));
    let o = gs(&small_run(r, "128", &["--save-interval", "1"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        staging.join("report.md").is_file(),
        "a save removed another command's staging"
    );
    assert!(
        !run.join(".groundscope-old.tmp").exists(),
        "a stale temporary file stays"
    );
    // The race itself: evaluations while the training saves at every update.
    let mut train = std::process::Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(small_run(r, "4096", &["--resume"]))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    for i in 0..4 {
        let o = gs(&[
            "eval",
            "--checkpoint",
            "bot",
            "--sizes",
            "5",
            "--objects",
            "1",
            "--seeds",
            "1",
            "--episodes",
            "2",
            "--quiet",
            "--out",
            r,
        ]);
        assert_eq!(o.status.code(), Some(0), "{i}: {}", stderr(&o));
        for f in [
            "report.md",
            "report.json",
            "performance.csv",
            "episodes.csv",
        ] {
            assert!(run.join(f).is_file(), "{i}: {f} missing after exit 0");
        }
        for f in ["report.md", "performance.csv"] {
            std::fs::remove_file(run.join(f)).unwrap();
        }
    }
    let status = common::wait_for_exit(&mut train, "the training");
    assert!(status.success());
}

/// `eval`'s terminal summary aligns long level ids (it used to push their columns out of
/// line) and gives one seed's cells as the mean alone, without a `± 0.000` of no spread.
#[test]
fn the_terminal_summary_aligns_long_ids_and_drops_a_spread_of_one_seed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = gs(&[
        "eval",
        "--checkpoint",
        "bot",
        "--levels",
        "BabyAI-GoToRedBall-v0,BabyAI-PutNextS7N4Carrying-v0",
        "--seeds",
        "1",
        "--episodes",
        "3",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    let table: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("checkpoint"))
        .take(3)
        .collect();
    assert_eq!(table.len(), 3, "{text}");
    assert!(!text.contains('±'), "{text}");
    // Every row's reward column starts where the header's does.
    let at = table[0].find("reward").unwrap();
    for row in &table[1..] {
        let level_end = row.find("-v0").unwrap() + 3;
        assert!(level_end < at, "the level overflows its column: {row:?}");
    }
}

/// A misspelt flag, subcommand or value names the one meant, in the one line of the error.
#[test]
fn typos_get_did_you_mean() {
    for (args, says) in [
        (&["eval", "--episodez", "3"][..], "did you mean --episodes?"),
        (&["evl"][..], "did you mean eval?"),
        (
            &["curve", "x.csv", "--out", "x.png", "--accuracy", "acc-nq"][..],
            "did you mean acc-ng?",
        ),
    ] {
        let o = gs(args);
        assert_bad_input(&o, says);
    }
}

/// A refusal on a level the model cannot read names the bundled agents that can.
#[test]
fn a_level_the_model_cannot_read_names_the_babyai_agent() {
    let o = gs(&[
        "replay",
        "--checkpoint",
        "bundled:attention",
        "--level",
        "BabyAI-GoToDoor-v0",
        "--seed",
        "1",
    ]);
    assert_bad_input(&o, "--checkpoint bundled:babyai");
    // One BabyAI agent is bundled; the names it replaced are not offered.
    assert!(
        !stderr(&o).contains("bundled:babyai-grounded"),
        "{}",
        stderr(&o)
    );
}

/// The name the BabyAI agent had until 2026-12-02 opens it and says so once; the removed
/// checkpoint's name is refused naming what replaced it.
#[test]
fn old_bundled_names_say_what_they_open_now() {
    let o = gs(&[
        "replay",
        "--checkpoint",
        "bundled:babyai-grounded2",
        "--level",
        "BabyAI-GoToLocal-v0",
        "--seed",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(
        err.matches("note: bundled:babyai-grounded2: it is bundled:babyai now")
            .count(),
        1,
        "{err}"
    );
    let o = gs(&[
        "replay",
        "--checkpoint",
        "bundled:babyai-grounded",
        "--level",
        "BabyAI-GoToLocal-v0",
    ]);
    assert_bad_input(
        &o,
        "bundled:babyai-grounded: it is no longer bundled; bundled:babyai",
    );
}
