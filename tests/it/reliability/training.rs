//! Reliability, round 5 (issue #68): every level evaluates, training's edge cases and the
//! checks on what a run resumes from. Each test failed before its fix.

use crate::common::{self, assert_bad_input, csv_rows, gs, small_run, small_train, stderr, stdout};

use std::path::Path;

/// One small imitation update (4 × 16 frames, no tracked evaluation) on the levels `levels`
/// gives (`--level ID` or `--levels …`), into `out`.
fn imitation_update<'a>(out: &'a str, levels: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["train", "--imitate"];
    a.extend_from_slice(levels);
    a.extend_from_slice(&[
        "--out",
        out,
        "--frames",
        "64",
        "--procs",
        "4",
        "--frames-per-proc",
        "16",
        "--batch-size",
        "32",
        "--hidden",
        "16",
        "--eval-interval",
        "0",
        "--quiet",
    ]);
    a
}

/// The update numbers of a run's `log.csv` rows.
fn logged_updates(run: &Path) -> Vec<u64> {
    csv_rows(&run.join("log.csv"))
        .iter()
        .map(|r| r["update"].parse().unwrap())
        .collect()
}

/// The PutNext…Carrying levels start with the moved object in the agent's hands: removing the
/// distractors leaves an instruction that resolves nowhere. The counterfactual of such a
/// failure is skipped and counted; the evaluation goes on and writes its whole report.
#[test]
fn an_evaluation_on_a_carrying_level_keeps_its_report_when_a_counterfactual_cannot_be_built() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let o = gs(&[
        "eval",
        "--checkpoint",
        "bot",
        "--level",
        "BabyAI-PutNextS5N2Carrying-v0",
        "--seeds",
        "1",
        "--episodes",
        "40",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let eps = csv_rows(&out.join("episodes.csv"));
    assert_eq!(eps.len(), 40);
    let failed = eps.iter().filter(|r| r["success"] != "1").count();
    assert!(
        failed > 0,
        "the bot fails some episodes of this level: {md}"
    );
    assert!(
        md.contains("not built:") && md.contains("could not be re-run without distractors"),
        "{md}"
    );
    assert!(
        stdout(&o).contains("could not be re-run without distractors"),
        "{}",
        stdout(&o)
    );
}

/// One chunk per process (`--frames-per-proc` = `--recurrence`) with one epoch: torch-ac's
/// shifted batches of every second update are empty, which made the update's losses 0/0.
/// Both PPO and imitation train through it.
#[test]
fn one_chunk_per_process_with_one_epoch_trains() {
    let dir = tempfile::tempdir().unwrap();
    for (name, extra) in [
        ("ppo", &[][..]),
        (
            "il",
            &["--imitate", "--level", "BabyAI-GoToLocalS6N3-v0"][..],
        ),
    ] {
        let run = dir.path().join(name);
        let mut args = small_train(run.to_str().unwrap(), "256", extra);
        args.extend_from_slice(&[
            "--epochs",
            "1",
            "--frames-per-proc",
            "8",
            "--recurrence",
            "8",
            "--batch-size",
            "16",
        ]);
        if name == "il" {
            // The level replaces the paper's size and objects.
            for flag in ["--size", "--objects", "--tasks", "--no-done"] {
                let i = args.iter().position(|a| *a == flag).unwrap();
                args.remove(i);
                if flag != "--no-done" {
                    args.remove(i);
                }
            }
        }
        let o = gs(&args);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        let log = csv_rows(&run.join("log.csv"));
        assert_eq!(log.len(), 8, "{name}");
        for r in &log {
            let loss: f64 = r["policy_loss"].parse().unwrap();
            let norm: f64 = r["grad_norm"].parse().unwrap();
            assert!(loss.is_finite() && norm > 0.0, "{name}: {r:?}");
        }
    }
}

/// `--init` from a model of the paper's 25 words onto a level whose missions use others used
/// to be accepted and fail about 70 updates later (and its `--resume` at once). Refused at
/// start, naming a word; a level the paper's words cover still warm-starts.
#[test]
fn init_from_a_model_that_lacks_the_levels_words_is_refused_naming_one() {
    let dir = tempfile::tempdir().unwrap();
    let parent = dir.path().join("paper");
    let o = gs(&["init", "--out", parent.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let run = dir.path().join("run");
    let args = |level: &'static str| {
        vec![
            "train".to_owned(),
            "--init".to_owned(),
            parent.to_str().unwrap().to_owned(),
            "--level".to_owned(),
            level.to_owned(),
            "--out".to_owned(),
            run.to_str().unwrap().to_owned(),
            "--frames".to_owned(),
            "64".to_owned(),
            "--procs".to_owned(),
            "4".to_owned(),
            "--frames-per-proc".to_owned(),
            "16".to_owned(),
            "--batch-size".to_owned(),
            "32".to_owned(),
            "--eval-interval".to_owned(),
            "0".to_owned(),
            "--quiet".to_owned(),
        ]
    };
    let as_str = |v: &[String]| v.iter().map(String::as_str).collect::<Vec<_>>().join(" ");
    let o = gs(&args("BabyAI-GoToDoor-v0")
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>());
    assert_bad_input(&o, "\"door\"");
    assert!(stderr(&o).contains("BabyAI-GoToDoor-v0"), "{}", stderr(&o));
    assert!(!run.exists(), "a refused run leaves no directory");
    let ok = args("BabyAI-GoToRedBall-v0");
    let o = gs(&ok.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(0), "{}: {}", as_str(&ok), stderr(&o));
}

/// `init --level ID` makes a model that reads the level it was made for (it used to get the
/// paper's 25 words and refuse BossLevel's missions).
#[test]
fn init_for_a_babyai_level_reads_that_level() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("boss");
    let m = model.to_str().unwrap();
    let o = gs(&["init", "--level", "BabyAI-BossLevel-v0", "--out", m]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = dir.path().join("r");
    let o = gs(&[
        "eval",
        "--checkpoint",
        m,
        "--level",
        "BabyAI-BossLevel-v0",
        "--seeds",
        "1",
        "--episodes",
        "3",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// `--resume` reads the logs only when they are regular files (a FIFO used to hang it) and
/// match the checkpoint: a deleted row, a short log, garbage, a missing log or a line cut
/// short inside the file are refused naming the file; a last line cut short by a crash is
/// dropped, as rows past the checkpoint are.
#[test]
fn resume_refuses_logs_that_do_not_match_the_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("base");
    let b = base.to_str().unwrap();
    let o = gs(&small_run(b, "256", &["--save-interval", "1"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let log = std::fs::read_to_string(base.join("log.csv")).unwrap();
    let lines: Vec<&str> = log.lines().collect();
    assert_eq!(lines.len(), 5, "{log}");
    let joined = |ls: &[&str]| ls.iter().map(|l| format!("{l}\n")).collect::<String>();
    let cut = &lines[4][..lines[4].len() / 2];
    let cases: Vec<(&str, &str, Option<String>, &str)> = vec![
        (
            "deleted-row",
            "log.csv",
            Some(joined(&[lines[0], lines[1], lines[3], lines[4]])),
            "update 3 follows update 1",
        ),
        (
            "short",
            "log.csv",
            Some(joined(&lines[..3])),
            "ends at update 2",
        ),
        (
            "garbage",
            "log.csv",
            Some(format!(
                "{}garbage\n{}",
                joined(&lines[..2]),
                joined(&lines[2..])
            )),
            "line 3",
        ),
        (
            "header-only",
            "log.csv",
            Some(joined(&lines[..1])),
            "ends at update 0",
        ),
        (
            "not-a-log",
            "log.csv",
            Some("hello\n".into()),
            "not a training log",
        ),
        ("missing", "log.csv", None, "log.csv"),
        (
            "cut-inside",
            "log.csv",
            Some(format!(
                "{}{cut}\n{}",
                joined(&lines[..4]),
                joined(&lines[4..])
            )),
            "line 5",
        ),
        (
            "eval-garbage",
            "eval_log.csv",
            Some("update,frames\n1,2\n".into()),
            "not a training log",
        ),
        ("fifo", "eval_log.csv", None, "FIFO"),
    ];
    for (name, file, text, says) in cases {
        let run = dir.path().join(name);
        copy_dir(&base, &run);
        let path = run.join(file);
        std::fs::remove_file(&path).unwrap();
        match (&text, name) {
            (Some(t), _) => std::fs::write(&path, t).unwrap(),
            (None, "fifo") => {
                let ok = std::process::Command::new("mkfifo")
                    .arg(&path)
                    .status()
                    .unwrap();
                assert!(ok.success());
            }
            (None, _) => {}
        }
        let before = std::fs::read(run.join("model.safetensors")).unwrap();
        let o = common::gs_guarded(&small_run(run.to_str().unwrap(), "512", &["--resume"]));
        assert_bad_input(&o, file);
        assert!(stderr(&o).contains(says), "{name}: {}", stderr(&o));
        assert_eq!(
            std::fs::read(run.join("model.safetensors")).unwrap(),
            before,
            "{name}"
        );
        if let Some(t) = text {
            assert_eq!(
                std::fs::read_to_string(&path).unwrap(),
                t,
                "{name}: the log was rewritten"
            );
        }
    }
    // A crash while appending: the last line cut short, for an update past the checkpoint.
    let run = dir.path().join("crashed");
    copy_dir(&base, &run);
    let ghost = format!("5{}", &lines[4][lines[4].find(',').unwrap()..]);
    std::fs::write(
        run.join("log.csv"),
        format!("{}{}", joined(&lines), &ghost[..ghost.len() / 2]),
    )
    .unwrap();
    let o = gs(&small_run(run.to_str().unwrap(), "320", &["--resume"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(logged_updates(&run), [1, 2, 3, 4, 5]);
    // Killed before its first save: log rows and no checkpoint. The refusal says what to do.
    let early = dir.path().join("early");
    std::fs::create_dir_all(&early).unwrap();
    std::fs::write(early.join("log.csv"), joined(&lines[..2])).unwrap();
    let o = gs(&small_run(early.to_str().unwrap(), "320", &["--resume"]));
    assert_bad_input(&o, "no checkpoint");
    assert!(stderr(&o).contains("without --resume"), "{}", stderr(&o));
}

/// Copies a run directory (files and the checkpoints' generations).
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dest = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}

/// `--save-interval` is kept with the run, as the tracking flags are (it used to go back to
/// 10 on `--resume`); a mode flag that contradicts the run is refused, `--done` included
/// (it used to be ignored in silence).
#[test]
fn resume_keeps_the_save_interval_and_refuses_a_contradicting_done_flag() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let r = run.to_str().unwrap();
    let o = gs(&small_run(r, "128", &["--save-interval", "2"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = gs(&small_run(r, "320", &["--resume"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let gens: Vec<String> = std::fs::read_dir(run.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        gens.contains(&"update-00000004".to_owned())
            && gens.contains(&"update-00000005".to_owned()),
        "a checkpoint every 2 updates, then the last: {gens:?}"
    );
    // A registered-mode BabyAI run, resumed with --done.
    let il = dir.path().join("il");
    let args = |extra: &[&'static str]| {
        let mut a = imitation_update(il.to_str().unwrap(), &["--level", "BabyAI-GoToRedBall-v0"]);
        a.extend_from_slice(extra);
        a.into_iter().map(str::to_owned).collect::<Vec<_>>()
    };
    let o = gs(&args(&[]).iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut again = args(&["--resume", "--done"]);
    // As a user resumes: the run's directory and the flag, the level left to the run.
    let i = again.iter().position(|a| a == "--level").unwrap();
    again.drain(i..i + 2);
    again.retain(|a| a != "--imitate");
    for a in &mut again {
        if a == "64" {
            *a = "128".to_owned();
        }
    }
    let o = gs(&again.iter().map(String::as_str).collect::<Vec<_>>());
    assert_bad_input(&o, "--done");
    assert!(
        stderr(&o).contains("without the done action"),
        "{}",
        stderr(&o)
    );
}

/// Level weights stay in a range where they sum and print as numbers; a run's saved mix is
/// checked on `--resume` as the flag is.
#[test]
fn level_weights_out_of_range_are_refused_on_the_flag_and_in_a_saved_run() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("mix");
    let r = run.to_str().unwrap();
    let args = |levels: &'static str, extra: &[&'static str]| {
        let mut a = imitation_update(r, &["--levels", levels]);
        a.extend_from_slice(extra);
        a
    };
    let o = gs(&args(
        "BabyAI-GoToRedBall-v0:1e308,BabyAI-GoToLocal-v0:1e308",
        &[],
    ));
    assert_bad_input(&o, "1e6");
    assert!(!run.exists());
    let o = gs(&args("BabyAI-GoToRedBall-v0:2,BabyAI-GoToLocal-v0", &[]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("×2"), "{}", stdout(&o));
    let resume_json = run.join("checkpoints/update-00000001/resume.json");
    let text = std::fs::read_to_string(&resume_json).unwrap();
    assert!(text.contains("\"weight\":2.0"), "{text}");
    std::fs::write(
        &resume_json,
        text.replace("\"weight\":2.0", "\"weight\":-2.0"),
    )
    .unwrap();
    let mut resume: Vec<&str> = args("BabyAI-GoToRedBall-v0", &["--resume"]);
    let i = resume.iter().position(|a| *a == "--levels").unwrap();
    resume.drain(i..i + 2);
    resume.retain(|a| *a != "--imitate");
    let o = gs(&resume);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("-2"), "{}", stderr(&o));
}

/// Imitation needs the bot's labels: a level where it gives up at once is named in a warning,
/// and a run where no level gives any is refused (it used to train on nothing and exit 0).
/// `--init bot` says the bot has no weights (it used to look for `bot.json`).
#[test]
fn imitation_without_labels_is_named_and_the_bot_cannot_seed_a_network() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("il");
    let r = run.to_str().unwrap();
    let args = |levels: &'static str| imitation_update(r, &["--levels", levels]);
    let o = gs(&args("BabyAI-KeyInBox-v0"));
    assert_bad_input(&o, "BabyAI-KeyInBox-v0");
    assert!(stderr(&o).contains("no labelled frame"), "{}", stderr(&o));
    assert!(!run.exists());
    let o = gs(&args("BabyAI-KeyInBox-v0,BabyAI-GoToRedBall-v0"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning") && stderr(&o).contains("BabyAI-KeyInBox-v0"),
        "{}",
        stderr(&o)
    );
    let o = gs(&[
        "train",
        "--init",
        "bot",
        "--out",
        dir.path().join("x").to_str().unwrap(),
    ]);
    assert_bad_input(&o, "--init bot");
    assert!(stderr(&o).contains("--imitate"), "{}", stderr(&o));
    let help = stdout(&gs(&["eval", "--help"]));
    assert!(help.contains("`bot`"), "{help}");
}
