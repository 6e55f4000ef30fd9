//! `groundscope study`: plan a spec into typed runs, run them here N at a time (resumable,
//! never one task twice), exec one run, and collect the finished runs into one report.

use crate::common::{self, assert_bad_input, gs, stderr, stdout};

use std::path::Path;

/// A study of tiny runs: `seeds` × two recipes on the paper's smallest level. When `broken`,
/// the training of one (`other`) fails when it starts: its `--init` names no checkpoint, which
/// only the training reads (a plan refuses the values every run refuses, `--hidden 0`).
pub(crate) fn spec(seeds: &str, broken: bool) -> String {
    format!(
        r#"seeds = {seeds}
frames = 128
eval = ["--seeds", "1", "--episodes", "4"]

[recipes]
tiny = ["--procs", "4", "--frames-per-proc", "16", "--batch-size", "32", "--hidden", "16",
        "--eval-interval", "0", "--size", "5", "--objects", "1", "--tasks", "goto", "--no-done"]
other = ["--procs", "4", "--frames-per-proc", "16", "--batch-size", "32", "--hidden", "8",
         "--eval-interval", "0", "--size", "5", "--objects", "1", "--tasks", "goto", "--no-done"{}]

[levels]
small = {{ train = [], eval = ["--sizes", "5", "--objects", "1"] }}
"#,
        if broken {
            ", \"--init\", \"no-such-parent\""
        } else {
            ""
        }
    )
}

/// `study plan DIR/study.toml --out DIR/study`, the spec being `text`.
pub(crate) fn plan(dir: &Path, text: &str) -> std::process::Output {
    let spec = dir.join("study.toml");
    std::fs::write(&spec, text).unwrap();
    gs(&[
        "study",
        "plan",
        spec.to_str().unwrap(),
        "--out",
        dir.join("study").to_str().unwrap(),
    ])
}

/// A file's text, failing naming it.
pub(crate) fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn a_plan_writes_the_lines_the_engines_run_and_only_grows() {
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1, 2]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("planned 4 runs"), "{}", stdout(&o));
    let study = dir.path().join("study");
    let files = [
        "study.toml",
        "manifest.json",
        "commands.txt",
        "slurm.sbatch",
        "ray_driver.py",
    ];
    let before: Vec<String> = files.iter().map(|f| read(&study.join(f))).collect();
    let lines: Vec<&str> = before[2].lines().collect();
    assert_eq!(lines.len(), 4);
    let abs = std::fs::canonicalize(&study).unwrap();
    assert!(
        lines[0].ends_with(&format!("study exec {} other-small-s1", abs.display())),
        "{}",
        lines[0]
    );
    assert!(before[3].contains("#SBATCH --array=0-3") && before[3].contains("commands.txt"));
    assert!(before[4].contains("num_cpus") && before[4].contains(&abs.display().to_string()));
    let manifest: serde_json::Value = serde_json::from_str(&before[1]).unwrap();
    assert_eq!(manifest["runs"][0]["name"], "other-small-s1");
    assert_eq!(manifest["runs"][0]["threads"], 1);
    // The same spec again: the same bytes.
    let o = plan(dir.path(), &spec("[1, 2]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let again: Vec<String> = files.iter().map(|f| read(&study.join(f))).collect();
    assert_eq!(again, before);
    // Added seeds are accepted; a changed run is refused by name and changes nothing.
    let o = plan(dir.path(), &spec("[1, 2, 3]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(read(&study.join("commands.txt")).lines().count(), 6);
    let grown = read(&study.join("manifest.json"));
    let o = plan(dir.path(), &spec("[1, 2, 3]", true));
    assert_bad_input(&o, "changes run other-small-s1");
    assert_eq!(read(&study.join("manifest.json")), grown);
    let o = plan(dir.path(), &spec("[2, 3]", false));
    assert_bad_input(&o, "drops run other-small-s1");
    // A typo in a recipe is refused at plan time, naming the recipe; nothing is written.
    let typo = dir.path().join("typo");
    std::fs::create_dir_all(&typo).unwrap();
    let o = plan(
        &typo,
        &spec("[1]", false).replace("--batch-size", "--batch-sise"),
    );
    assert_bad_input(&o, "recipe other");
    assert!(stderr(&o).contains("--batch-sise"), "{}", stderr(&o));
    assert!(!typo.join("study").exists());
    // A flag the plan owns, a bad TOML, a missing spec.
    let o = plan(
        &typo,
        &spec("[1]", false).replace("\"--hidden\", \"16\"", "\"--out\", \"x\""),
    );
    assert_bad_input(&o, "recipe tiny gives --out");
    let o = plan(&typo, "seeds = [1");
    assert_bad_input(&o, "study.toml");
    let o = gs(&["study", "run", typo.join("nothing").to_str().unwrap()]);
    assert_bad_input(&o, "manifest.json");
}

#[test]
fn a_study_runs_here_resumes_never_runs_a_task_twice_and_collects() {
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1, 2]", true));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    // Two runners at once: every run trains once, whoever runs it.
    let spawn = || {
        std::process::Command::new(env!("CARGO_BIN_EXE_groundscope"))
            .args(["study", "run", s, "--jobs", "2", "--quiet"])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn(), spawn());
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    // The broken recipe (`--init` of no checkpoint) fails: reported with its log; the others
    // go on.
    for o in [&a, &b] {
        assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(o));
    }
    let runs = study.join("runs");
    for seed in [1, 2] {
        let run = runs.join(format!("tiny-small-s{seed}"));
        assert!(run.join("study-done.json").is_file(), "{}", run.display());
        assert!(run.join("eval/report.md").is_file());
        let log = read(&run.join("study.log"));
        assert_eq!(log.matches("== groundscope train").count(), 1, "{log}");
        let broken = runs.join(format!("other-small-s{seed}"));
        assert!(broken.join("study-failed.json").is_file());
        assert!(read(&broken.join("study-failed.json")).contains("train"));
    }
    let all = format!("{}{}", stdout(&a), stdout(&b));
    assert!(all.contains("failed"), "{all}");
    // Collect names the failed runs and reports the finished ones over their seeds.
    let o = gs(&["study", "collect", s]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("collected 2 finished runs of 4"),
        "{}",
        stdout(&o)
    );
    let report = study.join("report");
    let md = read(&report.join("report.md"));
    assert!(
        md.contains("failed (2): other-small-s1, other-small-s2"),
        "{md}"
    );
    assert!(md.contains("| tiny | small | S5N1 | 2 |"), "{md}");
    let csv = read(&report.join("results.csv"));
    assert!(
        csv.lines()
            .any(|l| l.starts_with("tiny,small,S5N1,2,success,")),
        "{csv}"
    );
    assert!(report.join("curves_small.png").is_file());
    // A killed run resumes: its training goes on from its checkpoint, not from the start.
    let killed = runs.join("tiny-small-s2");
    std::fs::remove_file(killed.join("study-done.json")).unwrap();
    let o = gs(&["study", "exec", s, "tiny-small-s2"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let log = read(&killed.join("study.log"));
    assert!(
        log.lines()
            .rfind(|l| l.starts_with("== groundscope train"))
            .unwrap()
            .ends_with("--resume"),
        "{log}"
    );
    // A finished run is left alone; an unknown run is named.
    let o = gs(&["study", "exec", s, "tiny-small-s2"]);
    assert_eq!(stdout(&o).trim(), "tiny-small-s2: done");
    let o = gs(&["study", "exec", s, "tiny-small-s9"]);
    assert_bad_input(&o, "tiny-small-s9");
}

/// A run killed (SIGKILL) in the middle of its training is run again by the same line and goes
/// on from its last checkpoint: one continuous log, the same weights as a run never killed.
#[test]
fn a_killed_run_resumes_from_its_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let text = spec("[1]", false)
        .replace("frames = 128", "frames = 12800")
        .replace(
            "\"--eval-interval\", \"0\"",
            "\"--eval-interval\", \"0\", \"--save-interval\", \"2\"",
        );
    let o = plan(dir.path(), &text);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    let run = study.join("runs/tiny-small-s1");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(["study", "exec", s, "tiny-small-s1"])
        .spawn()
        .unwrap();
    common::wait_until("a first checkpoint", || {
        std::fs::read_dir(run.join("checkpoints")).is_ok_and(|d| {
            d.filter_map(Result::ok)
                .any(|e| e.file_name().to_string_lossy().starts_with("update-"))
        })
    });
    // The exec killed: its training, which runs inside it, ends with it, and the system
    // frees the run's lock with them; neither done nor failed.
    let _ = child.kill();
    let _ = child.wait();
    assert!(!run.join("study-done.json").exists());
    assert!(!run.join("study-failed.json").exists());
    let o = gs(&["study", "exec", s, "tiny-small-s1"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(run.join("study-done.json").is_file());
    let log = read(&run.join("log.csv"));
    let updates: Vec<u64> = log
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(updates, (1..=200).collect::<Vec<_>>(), "{log}");
    assert!(read(&run.join("study.log")).contains("--resume"));
    // The same run never killed ends with the same weights: its recipe's flags (as the spec
    // gives them) with the seed and frames the plan gives it.
    let straight = dir.path().join("straight");
    let args = [
        "train",
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
        "--save-interval",
        "2",
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
        "12800",
        "--quiet",
        "--out",
        straight.to_str().unwrap(),
    ];
    assert!(text.contains(
        r#"tiny = ["--procs", "4", "--frames-per-proc", "16", "--batch-size", "32", "--hidden", "16",
        "--eval-interval", "0", "--save-interval", "2", "--size", "5", "--objects", "1", "--tasks", "goto", "--no-done"]"#
    ));
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(run.join("model.safetensors")).unwrap(),
        std::fs::read(straight.join("model.safetensors")).unwrap()
    );
}

/// Ctrl-C (here SIGINT to the runner alone, as an engine's scancel or a kill would send it)
/// stops every running run at its next update, saved: the runner exits 130, no run is marked
/// failed or done, and no process of the study is left (a later `study run` resumes the runs
/// from their checkpoints, as the killed run's test shows).
#[test]
fn a_stopped_runner_leaves_runs_that_resume() {
    let dir = tempfile::tempdir().unwrap();
    let text = spec("[1]", false)
        .replace("frames = 128", "frames = 64000")
        .replace("tiny", "long");
    let o = plan(dir.path(), &text);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    let mut runner = std::process::Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(["study", "run", s, "--jobs", "2", "--quiet"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let runs = study.join("runs");
    common::wait_until("both runs logging", || {
        ["long-small-s1", "other-small-s1"].iter().all(|n| {
            std::fs::read_to_string(runs.join(n).join("log.csv"))
                .is_ok_and(|l| l.lines().count() > 2)
        })
    });
    let ok = std::process::Command::new("kill")
        .args(["-INT", &runner.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
    let status = common::wait_for_exit(&mut runner, "the stopped runner");
    assert_eq!(status.code(), Some(130));
    for n in ["long-small-s1", "other-small-s1"] {
        let run = runs.join(n);
        assert!(!run.join("study-failed.json").exists(), "{n}");
        assert!(!run.join("study-done.json").exists(), "{n}");
        let log = read(&run.join("study.log"));
        assert!(log.contains("interrupted; saved"), "{n}: {log}");
    }
    // No process of the study is left running.
    common::wait_until("the study's processes to end", || {
        std::process::Command::new("pgrep")
            .args(["-f", s])
            .output()
            .is_ok_and(|o| o.stdout.is_empty())
    });
}
