//! `groundscope study` when things go wrong (#81): the Slurm log directory, the faithfulness
//! figures, a failing run under the runner, a failed plan, negative counts, user text in
//! errors, and a hand-edited manifest.

use crate::common::{assert_bad_input, entries, gs, stderr, stdout};
use crate::study::{plan, read, spec};

use std::path::Path;
use std::process::Command;

/// The canonical path of `dir/study` as text (what the plan writes into its files).
fn study_of(dir: &Path) -> String {
    std::fs::canonicalize(dir.join("study"))
        .unwrap()
        .display()
        .to_string()
}

/// An error as the user sees it: one line, short, without a raw control character.
fn assert_short_and_clean(o: &std::process::Output, what: &str) {
    assert_bad_input(o, what);
    let err = stderr(o);
    let line = err.trim_end();
    assert!(
        line.len() < 1024,
        "{} bytes: {}",
        line.len(),
        line.chars().take(200).collect::<String>()
    );
    assert!(
        !line.chars().any(char::is_control),
        "a raw control character: {line:?}"
    );
}

#[test]
fn a_plan_makes_the_slurm_log_directory_and_a_replan_keeps_it() {
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let logs = study.join("slurm-logs");
    assert!(logs.is_dir(), "{:?}", entries(&study));
    // slurm.sbatch writes its logs there (Slurm fails a task whose log directory is missing).
    let sbatch = read(&study.join("slurm.sbatch"));
    assert!(
        sbatch.contains(&format!("--output={}/slurm-logs/", study_of(dir.path()))),
        "{sbatch}"
    );
    // A replan (the same spec, or more seeds) keeps the directory and the logs in it.
    std::fs::write(logs.join("7_0.txt"), "a task's log").unwrap();
    for seeds in ["[1]", "[1, 2]"] {
        let o = plan(dir.path(), &spec(seeds, false));
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert_eq!(read(&logs.join("7_0.txt")), "a task's log");
    }
    // No staging directory is left beside the plan's files.
    assert_eq!(
        entries(&study),
        [
            "commands.txt",
            "manifest.json",
            "ray_driver.py",
            "slurm-logs",
            "slurm.sbatch",
            "study.toml"
        ]
    );
}

#[test]
fn collect_reads_the_faithfulness_report_the_command_writes() {
    let dir = tempfile::tempdir().unwrap();
    // The top-level `eval` only: the level set's inline table has one too.
    let text = spec("[1]", false).replacen(
        "eval = [",
        "faithfulness = [\"--seeds\", \"1\", \"--episodes\", \"2\"]\neval = [",
        1,
    );
    let o = plan(dir.path(), &text);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    let o = gs(&["study", "exec", s, "tiny-small-s1"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let faith = study.join("runs/tiny-small-s1/faithfulness/faithfulness.json");
    assert!(
        faith.is_file(),
        "the faithfulness step writes {}",
        faith.display()
    );
    let o = gs(&["study", "collect", s]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let csv = read(&study.join("report/results.csv"));
    // The faithfulness figures are in the evaluation's row of the level (`S5N1`, which the
    // faithfulness report calls `S5N1 goto`).
    assert!(
        csv.lines()
            .any(|l| l.starts_with("tiny,small,S5N1,1,faith_none_success,")),
        "{csv}"
    );
    let j: serde_json::Value = serde_json::from_str(&read(&faith)).unwrap();
    if j["checkpoints"][0]["localisation"]["combined"]["pointing_game"]["value"]["mean"].is_number()
    {
        assert!(
            csv.lines()
                .any(|l| l.starts_with("tiny,small,S5N1,1,faith_m_pointing,")),
            "{csv}"
        );
    }
    let md = read(&study.join("report/report.md"));
    assert!(md.contains("faith_none_success"), "{md}");
}

#[test]
fn a_run_whose_exec_fails_is_a_failed_run_named_with_its_error() {
    // Both runs' directories are taken by files: each exec fails at once (exit 2) with its
    // error, which the runner shows; it used to say "stopped" and exit 0.
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    std::fs::create_dir_all(study.join("runs")).unwrap();
    for name in ["other-small-s1", "tiny-small-s1"] {
        std::fs::write(study.join("runs").join(name), "in the way").unwrap();
    }
    let o = gs(&["study", "run", s, "--jobs", "1", "--quiet"]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{}", stderr(&o));
    for name in ["other-small-s1", "tiny-small-s1"] {
        assert!(out.contains(&format!("{name}: failed (exit 2)")), "{out}");
    }
    assert!(out.contains("groundscope: creating"), "{out}");
    assert!(!out.contains("stopped"), "{out}");
    assert!(out.contains("0 of 2 runs done, 2 failed"), "{out}");
    assert!(
        stderr(&o).contains("failed runs: ") && stderr(&o).contains("tiny-small-s1"),
        "{}",
        stderr(&o)
    );
    // A training refused when it starts (`--init` of no checkpoint): the run is named with the
    // end of its study.log; the other run's exec fails too (its directory is taken).
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1]", true));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    std::fs::create_dir_all(study.join("runs")).unwrap();
    std::fs::write(study.join("runs/tiny-small-s1"), "in the way").unwrap();
    let o = gs(&["study", "run", s, "--jobs", "2", "--quiet"]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{}", stderr(&o));
    assert!(out.contains("other-small-s1: failed (exit 1)"), "{out}");
    assert!(out.contains("train failed"), "{out}");
    assert!(out.contains("study.log"), "{out}");
    assert!(out.contains("tiny-small-s1: failed (exit 2)"), "{out}");
}

/// `study plan` under a file-size limit of 1,024 bytes (`ulimit -f 2`, in 512-byte blocks):
/// the spec fits, the manifest and the Ray driver do not.
fn plan_limited(dir: &Path, text: &str) -> std::process::Output {
    let spec = dir.join("study.toml");
    std::fs::write(&spec, text).unwrap();
    Command::new("sh")
        .args(["-c", "ulimit -f 2; exec \"$0\" \"$@\""])
        .arg(env!("CARGO_BIN_EXE_groundscope"))
        .args(["study", "plan"])
        .arg(&spec)
        .arg("--out")
        .arg(dir.join("study"))
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap()
}

#[test]
fn a_failed_plan_leaves_no_new_study_and_a_failed_replan_the_old_files() {
    let files = [
        "study.toml",
        "manifest.json",
        "commands.txt",
        "slurm.sbatch",
        "ray_driver.py",
    ];
    // A new --out: nothing of it is left (it used to keep study.toml).
    let dir = tempfile::tempdir().unwrap();
    let o = plan_limited(dir.path(), &spec("[1, 2, 3]", false));
    assert_bad_input(&o, "File too large");
    assert_eq!(entries(dir.path()), ["study.toml"]);
    // A replan that fails while writing: the old files, byte for byte (it used to leave the
    // new study.toml beside the old manifest).
    let o = plan(dir.path(), &spec("[1]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let before: Vec<String> = files.iter().map(|f| read(&study.join(f))).collect();
    let o = plan_limited(dir.path(), &spec("[1, 2, 3]", false));
    assert_bad_input(&o, "File too large");
    let after: Vec<String> = files.iter().map(|f| read(&study.join(f))).collect();
    assert_eq!(after, before);
    assert!(
        entries(&study)
            .iter()
            .all(|n| !n.starts_with(".groundscope")),
        "{:?}",
        entries(&study)
    );
    // A replan refused at its checks changes nothing either.
    let o = plan(dir.path(), &spec("[1]", true));
    assert_bad_input(&o, "changes run other-small-s1");
    let after: Vec<String> = files.iter().map(|f| read(&study.join(f))).collect();
    assert_eq!(after, before);
    // A file in the way of one of the plan's files is refused before any file moves.
    std::fs::remove_file(study.join("ray_driver.py")).unwrap();
    std::fs::create_dir(study.join("ray_driver.py")).unwrap();
    let o = plan(dir.path(), &spec("[1, 2]", false));
    assert_bad_input(&o, "ray_driver.py");
    assert_eq!(read(&study.join("manifest.json")), before[1]);
    assert_eq!(read(&study.join("study.toml")), before[0]);
}

#[test]
fn negative_and_zero_counts_get_the_flags_own_message() {
    let dir = tempfile::tempdir().unwrap();
    let nothing = dir.path().join("nothing");
    let nothing = nothing.to_str().unwrap();
    for n in ["-1", "0"] {
        let o = gs(&["study", "run", nothing, "--jobs", n]);
        assert_bad_input(&o, &format!("--jobs {n}: must be at least 1"));
    }
    for n in ["-2", "0"] {
        let o = gs(&["bench", "study", "--runs", n]);
        assert_bad_input(&o, &format!("--runs {n}: must be at least 1"));
    }
    let o = gs(&["bench", "study", "--runs", "1", "--frames", "-2"]);
    assert_bad_input(&o, "--frames");
    let o = gs(&["bench", "study", "--runs", "1", "--frames", "0"]);
    assert_bad_input(&o, "--frames 0: must be at least 1");
}

#[test]
fn errors_quote_the_specs_text_escaped_and_cut() {
    let dir = tempfile::tempdir().unwrap();
    let base = spec("[1]", false);
    let long = "a".repeat(100_000);
    for (text, says) in [
        // A 100 KB recipe name (it used to be planned, naming directories no file system has).
        (
            base.replace("tiny = [", &format!("{long} = [")),
            "(100000 characters)",
        ),
        // A flag with an escape byte and one with a NUL (TOML's escapes), a 100 KB flag: clap's
        // message quotes them.
        (
            base.replace(
                "\"--no-done\"]\nother",
                "\"--no-done\", \"--x\\u001b[31m\"]\nother",
            ),
            "recipe tiny",
        ),
        (
            base.replace(
                "\"--no-done\"]\nother",
                "\"--no-done\", \"--x\\u0000y\"]\nother",
            ),
            "recipe tiny",
        ),
        (
            base.replace(
                "\"--no-done\"]\nother",
                &format!("\"--no-done\", \"--{long}\"]\nother"),
            ),
            "recipe tiny",
        ),
        // TOML's own errors: a 100 KB value of the wrong type, a raw escape byte in a string.
        (
            base.replace("frames = 128", &format!("frames = \"{long}\"")),
            "study.toml",
        ),
        (
            base.replace(
                "\"--no-done\"]\nother",
                "\"--no-done\", \"--x\u{1b}\"]\nother",
            ),
            "study.toml",
        ),
    ] {
        let o = plan(dir.path(), &text);
        assert_short_and_clean(&o, says);
        assert!(!dir.path().join("study").exists());
    }
    // A run name given to exec: quoted and cut too.
    let o = plan(dir.path(), &base);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let s = dir.path().join("study");
    let name = format!("x\u{1b}[31m{long}");
    let o = gs(&["study", "exec", s.to_str().unwrap(), name.as_str()]);
    assert_short_and_clean(&o, "has no run");
}

/// Rewrites `study`'s manifest.json with `edit` applied to its JSON.
fn edit_manifest(study: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let path = study.join("manifest.json");
    let mut m: serde_json::Value = serde_json::from_str(&read(&path)).unwrap();
    edit(&mut m);
    std::fs::write(&path, serde_json::to_string_pretty(&m).unwrap()).unwrap();
}

#[test]
fn a_hand_edited_manifest_is_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let o = plan(dir.path(), &spec("[1]", false));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let study = dir.path().join("study");
    let s = study.to_str().unwrap();
    let planned = read(&study.join("manifest.json"));
    // A run name that leaves runs/ (which a study that has run holds): refused by exec, run
    // and collect; nothing is made.
    let runs = study.join("runs");
    std::fs::create_dir_all(&runs).unwrap();
    edit_manifest(&study, |m| m["runs"][0]["name"] = "../../x".into());
    let o = gs(&["study", "exec", s, "../../x"]);
    assert_bad_input(&o, "../../x");
    assert!(stderr(&o).contains("not a plain name"), "{}", stderr(&o));
    for args in [["study", "run", s], ["study", "collect", s]] {
        let o = gs(&args);
        assert_bad_input(&o, "not a plain name");
    }
    assert_eq!(entries(dir.path()), ["study", "study.toml"]);
    assert!(entries(&runs).is_empty(), "{:?}", entries(&runs));
    // Edited steps (the evaluation's episodes, a typed field of its step) that no longer hash
    // to the run's hash: named, with the advice to plan again.
    std::fs::write(study.join("manifest.json"), &planned).unwrap();
    edit_manifest(&study, |m| {
        let episodes = &mut m["runs"][1]["eval"]["sweep"]["episodes"];
        assert_eq!(*episodes, 4);
        *episodes = 1.into();
    });
    let o = gs(&["study", "exec", s, "tiny-small-s1"]);
    assert_bad_input(&o, "run tiny-small-s1: its steps do not hash");
    assert!(
        stderr(&o).contains("plan the study again"),
        "{}",
        stderr(&o)
    );
    let o = gs(&["study", "run", s, "--quiet"]);
    assert_bad_input(&o, "tiny-small-s1");
    assert!(entries(&runs).is_empty(), "{:?}", entries(&runs));
    // The planned manifest runs as ever.
    std::fs::write(study.join("manifest.json"), &planned).unwrap();
    let o = gs(&["study", "exec", s, "tiny-small-s1"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}
