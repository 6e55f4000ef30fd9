//! Outputs that must leave the user's files as they were when the command fails (issue #81):
//! `replay`'s earlier outputs are never removed for a later one's failure, `eval
//! --export-failures` that fails keeps the earlier report with its recordings, two outputs
//! naming one file are refused before anything is written, and a Python policy's report is
//! not reopened as a checkpoint.

use crate::common::{SMALL_SWEEP, assert_bad_input, entries, gs, stderr};

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

/// Every file under `dir` (hidden ones included), by its path inside it, with its bytes.
fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let name = p.strip_prefix(root).unwrap().display().to_string();
                out.insert(name, std::fs::read(&p).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// `replay --seed 1` with `outputs` (flag and path pairs).
fn replay(outputs: &[(&str, &Path)]) -> std::process::Output {
    let mut args = vec!["replay", "--seed", "1"];
    for (flag, path) in outputs {
        args.extend([*flag, path.to_str().unwrap()]);
    }
    gs(&args)
}

/// A later output of `replay` that fails (a missing directory, a full device) leaves the
/// earlier outputs' files as they were: it used to remove the file the user already had,
/// after the new recording had replaced it.
#[test]
fn a_failing_later_output_keeps_the_earlier_outputs_old_files() {
    let tmp = tempfile::tempdir().unwrap();
    let rrd = tmp.path().join("old.rrd");
    let mcap = tmp.path().join("old.mcap");
    let missing = Path::new("/nonexistent-dir/x.mcap");
    let missing_trace = Path::new("/nonexistent-dir/t.json");
    let full = Path::new("/dev/full");
    // A full device under an MCAP's name (the flag wants the extension).
    let dev = tempfile::tempdir().unwrap();
    let full_mcap = dev.path().join("full.mcap");
    std::os::unix::fs::symlink(full, &full_mcap).unwrap();
    for outputs in [
        vec![("--save", rrd.as_path()), ("--mcap", missing)],
        // The MCAP fails as it is finished, after the recording was complete.
        vec![("--save", rrd.as_path()), ("--mcap", full_mcap.as_path())],
        vec![("--mcap", mcap.as_path()), ("--trace", missing_trace)],
        // The trace fails as it is written, after the MCAP was complete.
        vec![("--mcap", mcap.as_path()), ("--trace", full)],
        vec![
            ("--save", rrd.as_path()),
            ("--mcap", mcap.as_path()),
            ("--trace", full),
        ],
    ] {
        std::fs::write(&rrd, b"the user's old recording").unwrap();
        std::fs::write(&mcap, b"the user's old mcap").unwrap();
        let o = replay(&outputs);
        assert_eq!(o.status.code(), Some(2), "{outputs:?}: {}", stderr(&o));
        assert_eq!(stderr(&o).trim_end().lines().count(), 1, "{}", stderr(&o));
        assert!(
            !String::from_utf8_lossy(&o.stdout).contains("wrote"),
            "{outputs:?}: nothing is said to be written"
        );
        assert_eq!(std::fs::read(&rrd).unwrap(), b"the user's old recording");
        assert_eq!(std::fs::read(&mcap).unwrap(), b"the user's old mcap");
        // No temporary file is left beside them either.
        assert_eq!(entries(tmp.path()), ["old.mcap", "old.rrd"], "{outputs:?}");
    }
    // When every output succeeds they are all replaced.
    let trace = tmp.path().join("t.json");
    let o = replay(&[
        ("--save", rrd.as_path()),
        ("--mcap", mcap.as_path()),
        ("--trace", trace.as_path()),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::read(&rrd).unwrap().starts_with(b"RRF2"));
    assert!(std::fs::read(&mcap).unwrap().starts_with(b"\x89MCAP0\r\n"));
    assert!(serde_json::from_slice::<serde_json::Value>(&std::fs::read(&trace).unwrap()).is_ok());
    assert_eq!(entries(tmp.path()), ["old.mcap", "old.rrd", "t.json"]);
}

/// An `eval --export-failures` whose recordings fail (a file-size limit the report's files
/// stay under) leaves `--out` as it was, the earlier report and its recordings included: it
/// used to put its new report in place first, beside the earlier run's recordings, and exit 2.
#[test]
fn a_failing_export_keeps_the_earlier_report_and_recordings() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("report");
    let o = out.to_str().unwrap();
    let mut first = vec![
        "eval",
        "--out",
        o,
        "--export-failures",
        "--top-k",
        "2",
        "--quiet",
    ];
    first.extend(crate::common::FAILING_SWEEP);
    let r = gs(&first);
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    let before = tree(&out);
    let names = entries(&out);
    assert!(
        before.keys().any(|k| k.starts_with("failures/")),
        "{:?}",
        before.keys()
    );
    // A different sweep (one checkpoint, more episodes): its report would differ.
    // 200 blocks of 512 bytes: more than any file of the report (under 50 KB), less than a
    // recording (over 400 KB).
    let second = Command::new("sh")
        .args(["-c", "ulimit -f 200; exec \"$0\" \"$@\""])
        .arg(env!("CARGO_BIN_EXE_groundscope"))
        .args(["eval", "--out", o, "--export-failures", "--top-k", "2"])
        .args(["--checkpoint", "bundled:attention", "--quiet"])
        .args([
            "--sizes",
            "16",
            "--objects",
            "10",
            "--seeds",
            "1",
            "--episodes",
            "10",
        ])
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert_bad_input(&second, "File too large");
    // The error names where the recording was going, not a hidden directory.
    assert!(
        !stderr(&second).contains(".groundscope-"),
        "{}",
        stderr(&second)
    );
    assert!(stderr(&second).contains("failures/"), "{}", stderr(&second));
    let after = tree(&out);
    assert_eq!(
        after.keys().collect::<Vec<_>>(),
        before.keys().collect::<Vec<_>>()
    );
    assert!(after == before, "a file of the earlier run changed");
    assert_eq!(entries(&out), names, "nothing left beside them");
    // A `failures` that is not a directory is refused before anything runs.
    let file_out = tmp.path().join("other");
    std::fs::create_dir(&file_out).unwrap();
    std::fs::write(file_out.join("failures"), b"mine").unwrap();
    let mut args = vec![
        "eval",
        "--out",
        file_out.to_str().unwrap(),
        "--export-failures",
        "--quiet",
    ];
    args.extend(SMALL_SWEEP);
    assert_bad_input(&gs(&args), "not a directory");
    assert_eq!(entries(&file_out), ["failures"]);
}

/// Two outputs that name one file (by another spelling, through a link) are refused before
/// anything is written, in one line naming both flags: `replay` used to write both, say so
/// twice, and keep one.
#[test]
fn two_outputs_naming_one_file_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("d.rrd");
    let same = tmp.path().join(".").join("d.rrd");
    let o = replay(&[("--save", d.as_path()), ("--trace", same.as_path())]);
    assert_bad_input(&o, "name the same file");
    assert!(stderr(&o).contains("--save") && stderr(&o).contains("--trace"));
    assert!(entries(tmp.path()).is_empty(), "{:?}", entries(tmp.path()));
    // Through a subdirectory and back, and a link to a file the user has.
    std::fs::create_dir(tmp.path().join("sub")).unwrap();
    let m = tmp.path().join("x.mcap");
    let round = tmp.path().join("sub").join("..").join("x.mcap");
    let o = replay(&[("--trace", round.as_path()), ("--mcap", m.as_path())]);
    assert_bad_input(&o, "name the same file");
    assert!(stderr(&o).contains("--trace") && stderr(&o).contains("--mcap"));
    std::fs::write(&d, b"old").unwrap();
    let link = tmp.path().join("link.json");
    std::os::unix::fs::symlink(&d, &link).unwrap();
    let o = replay(&[("--save", d.as_path()), ("--trace", link.as_path())]);
    assert_bad_input(&o, "name the same file");
    assert_eq!(std::fs::read(&d).unwrap(), b"old");
    assert_eq!(entries(tmp.path()), ["d.rrd", "link.json", "sub"]);
    // `env show`'s two outputs follow the same rule.
    let png = tmp.path().join("level");
    let o = gs(&[
        "env",
        "show",
        "--seed",
        "3",
        "--png",
        png.to_str().unwrap(),
        "--snapshot",
        tmp.path().join("sub/../level").to_str().unwrap(),
    ]);
    assert_bad_input(&o, "name the same file");
    assert!(stderr(&o).contains("--png") && stderr(&o).contains("--snapshot"));
    assert!(!png.exists());
    // /dev/null may take several outputs (here under a recording's name too).
    let dev = tempfile::tempdir().unwrap();
    let null_rrd = dev.path().join("null.rrd");
    std::os::unix::fs::symlink("/dev/null", &null_rrd).unwrap();
    let o = replay(&[
        ("--save", null_rrd.as_path()),
        ("--trace", Path::new("/dev/null")),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// A report as `groundscope.evaluate` writes it for a Python policy named `name`: its
/// `report.json` (marked `python` unless `marked` is false, as reports written before the
/// field) and `episodes.csv` with one failed episode and the actions it took.
fn python_report(dir: &Path, name: &str, marked: bool) {
    std::fs::create_dir_all(dir).unwrap();
    let mut ckpt = serde_json::json!({
        "name": name, "variant": "baseline", "frames": null, "level": null,
    });
    if marked {
        ckpt["python"] = serde_json::json!(true);
    }
    let report = serde_json::json!({"mode": "greedy", "checkpoints": [ckpt]});
    std::fs::write(dir.join("report.json"), report.to_string()).unwrap();
    let actions = vec!["0"; 64].join(" ");
    std::fs::write(
        dir.join("episodes.csv"),
        format!(
            "checkpoint,level,level_seed,mission,success,steps,return,actions\n{name},BabyAI-GoToLocal-v0,3,go to the red ball,0,64,0,{actions}\n"
        ),
    )
    .unwrap();
}

/// A Python policy's episodes cannot be re-run: the report never resolves its name as a
/// checkpoint's (a policy named `bot`, or like a bundled checkpoint, is not opened as that
/// checkpoint), and `view --report` opens it read-only — past the report, as far as the
/// window — where it used to fail on "python.json: No such file or directory" or open the bot.
#[test]
fn a_python_policys_report_is_not_reopened_as_a_checkpoint() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, marked) in [
        ("bot", true),
        ("python", true),
        ("bundled:attention", true),
        ("python", false),
        ("bot", false),
    ] {
        let dir = tmp
            .path()
            .join(format!("{}-{marked}", name.replace(':', "_")));
        python_report(&dir, name, marked);
        let b = groundscope::metrics::report::browse::ReportEpisodes::open(&dir).unwrap();
        assert!(b.python.contains(name), "{name} {marked}");
        let e = b.episode(0).unwrap_err().to_string();
        assert!(
            e.contains("Python policy")
                && e.contains("groundscope.record(act, \"BabyAI-GoToLocal-v0\", 3"),
            "{e}"
        );
        // Read-only instead: its recorded actions, under its own name.
        let rec = b.recorded(0).unwrap();
        assert_eq!(
            (rec.policy.as_str(), rec.seed, rec.actions.len()),
            (name, 3, 64)
        );
        #[cfg(feature = "app")]
        {
            let o = Command::new(env!("CARGO_BIN_EXE_groundscope"))
                .args(["view", "--report", dir.to_str().unwrap()])
                .env("RAYON_NUM_THREADS", "1")
                .env_remove("DISPLAY")
                .env_remove("WAYLAND_DISPLAY")
                .output()
                .unwrap();
            // The report opened (no checkpoint to load, none refused): only the window is
            // missing here.
            assert_bad_input(&o, "no display");
            assert!(!stderr(&o).contains("Python policy"), "{}", stderr(&o));
        }
    }
    // The bot itself, as `eval --checkpoint bot` records it, still opens as the bot.
    let dir = tmp.path().join("the-bot");
    python_report(&dir, "bot", false);
    let report = serde_json::json!({"mode": "greedy", "checkpoints": [
        {"name": "bot", "variant": "bot", "frames": null, "level": null}
    ]});
    std::fs::write(dir.join("report.json"), report.to_string()).unwrap();
    let b = groundscope::metrics::report::browse::ReportEpisodes::open(&dir).unwrap();
    assert!(b.python.is_empty());
    assert_eq!(b.episode(0).unwrap().checkpoint, "bot");
    assert!(b.recorded(0).is_err(), "the bot is re-run, not replayed");
}
