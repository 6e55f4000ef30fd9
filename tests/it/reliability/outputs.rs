//! Bad and hostile inputs across the command line: one-line errors with exit 2, no panics, no
//! leftovers, outputs that never replace what they should write into.

use crate::common::{self, TINY_RUN, assert_bad_input, entries, gs, train_tiny as train};

use std::os::unix::fs::FileTypeExt as _;
use std::path::Path;
use std::process::{Command, Stdio};

#[test]
fn bad_training_settings_are_refused_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    for (flags, what) in [
        (&["--save-interval", "0"][..], "--save-interval"),
        (&["--procs", "0"][..], "--procs"),
        (&["--hidden", "0"][..], "lstm_hidden"),
        (&["--hidden", "100000"][..], "lstm_hidden"),
        (&["--reward-scale", "0"][..], "--reward-scale"),
        (&["--gae-lambda", "2"][..], "--gae-lambda"),
        (&["--discount", "1.5"][..], "--discount"),
        // A huge value is named as written, not as its 200 digits.
        (&["--discount", "1e200"][..], "--discount 1e200 must"),
        (
            &["--imitate-policy-share", "1e250"][..],
            "--imitate-policy-share 1e250 must",
        ),
        (&["--adam-eps", "0"][..], "--adam-eps"),
        (&["--entropy-coef", "-0.01"][..], "--entropy-coef"),
        (&["--value-loss-coef", "nan"][..], "--value-loss-coef"),
        (
            &["--eval-interval", "1", "--eval-episodes", "0"][..],
            "--eval-episodes",
        ),
        (&["--objects", "90", "--size", "16"][..], "n_objects"),
    ] {
        assert_bad_input(&train(&run, flags), what);
        assert!(!run.exists(), "{flags:?} left {run:?} behind");
    }
}

#[test]
fn a_resume_with_nothing_to_do_keeps_the_checkpoint_as_it_is() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    assert_eq!(train(&run, &["--frames", "32"]).status.code(), Some(0));
    let before = std::fs::read(run.join("model.json")).unwrap();
    let o = train(&run, &["--frames", "16", "--resume"]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(std::fs::read(run.join("model.json")).unwrap(), before);
    let meta: serde_json::Value = serde_json::from_slice(&before).unwrap();
    assert!(
        meta["training"]["success_rate"].is_number() || meta["training"]["success_rate"].is_null()
    );
    assert_eq!(meta["training"]["updates"], 2);
}

#[test]
fn sigterm_and_sighup_stop_training_with_a_saved_checkpoint() {
    for signal in ["TERM", "HUP"] {
        let tmp = tempfile::tempdir().unwrap();
        let run = tmp.path().join("run");
        let child = Command::new(env!("CARGO_BIN_EXE_groundscope"))
            .args(["train", "--out", run.to_str().unwrap(), "--quiet"])
            .args(TINY_RUN)
            .args(["--frames", "100000000", "--save-interval", "1000000"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Wait until it trains (its log has rows), then signal it.
        let mut child = child;
        common::wait_until("two rows in log.csv", || {
            assert!(child.try_wait().unwrap().is_none(), "the run ended");
            std::fs::read_to_string(run.join("log.csv")).is_ok_and(|t| t.lines().count() >= 3)
        });
        common::send_signal(&child, signal);
        let out = child.wait_with_output().unwrap();
        // Saved, and stopped short of its --frames: not finished (docs/training.md).
        assert_eq!(out.status.code(), Some(130), "SIG{signal}");
        assert!(String::from_utf8_lossy(&out.stdout).contains("interrupted; saved"));
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("not finished (exit 130)"),
            "SIG{signal}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let meta: serde_json::Value =
            serde_json::from_slice(&std::fs::read(run.join("model.json")).unwrap()).unwrap();
        assert!(
            meta["training"]["updates"].as_u64().unwrap() >= 2,
            "SIG{signal}"
        );
    }
}

#[test]
fn init_refuses_names_that_are_not_files_and_keeps_an_old_checkpoint() {
    let tmp = tempfile::tempdir().unwrap();
    for name in [".", "..", "dir/"] {
        let out = tmp.path().join(name);
        assert_bad_input(
            &gs(&[
                "init",
                "--model",
                "attention",
                "--seed",
                "1",
                "--out",
                out.to_str().unwrap(),
            ]),
            "not a checkpoint name",
        );
    }
    assert!(entries(tmp.path()).is_empty(), "{:?}", entries(tmp.path()));
    let name = tmp.path().join("m");
    let init = |seed: &str| {
        gs(&[
            "init",
            "--model",
            "attention",
            "--seed",
            seed,
            "--out",
            name.to_str().unwrap(),
        ])
    };
    assert_eq!(init("1").status.code(), Some(0));
    let old = std::fs::read(tmp.path().join("m.json")).unwrap();
    // A JSON that cannot be replaced (a directory in its place) leaves the old weights.
    let weights = std::fs::read(tmp.path().join("m.safetensors")).unwrap();
    std::fs::remove_file(tmp.path().join("m.json")).unwrap();
    std::fs::create_dir(tmp.path().join("m.json")).unwrap();
    assert_bad_input(&init("2"), "m.json");
    assert_eq!(
        std::fs::read(tmp.path().join("m.safetensors")).unwrap(),
        weights
    );
    assert_eq!(entries(tmp.path()), ["m.json", "m.safetensors"]);
    std::fs::remove_dir(tmp.path().join("m.json")).unwrap();
    std::fs::write(tmp.path().join("m.json"), &old).unwrap();
}

#[test]
fn outputs_write_into_devices_and_through_symlinks_without_replacing_them() {
    let tmp = tempfile::tempdir().unwrap();
    // A FIFO stands for a device: it must stay a FIFO and receive the bytes.
    let fifo = tmp.path().join("fifo.json");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    let o = gs(&[
        "env",
        "show",
        "--seed",
        "3",
        "--snapshot",
        fifo.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let bytes = reader.join().unwrap();
    assert!(serde_json::from_slice::<serde_json::Value>(&bytes).is_ok());
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );
    // A full device is an error, exit 2.
    assert_bad_input(
        &gs(&["env", "show", "--seed", "3", "--png", "/dev/full"]),
        "/dev/full",
    );
    // A symlink stays a link; its target gets the picture.
    let target = tmp.path().join("real.png");
    std::fs::write(&target, b"old").unwrap();
    let link = tmp.path().join("link.png");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let o = gs(&[
        "env",
        "show",
        "--seed",
        "3",
        "--png",
        link.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0));
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(std::fs::read(&target).unwrap().starts_with(b"\x89PNG"));
    assert_eq!(entries(tmp.path()), ["fifo.json", "link.png", "real.png"]);
}

/// `replay` of a million episodes with `stdout`: far more output than a pipe holds, and hours
/// of work for a run that went on after its reader left.
fn endless_replay(stdout: impl Into<Stdio>) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(["replay", "--seed", "0", "--episodes", "1000000"])
        .env("RAYON_NUM_THREADS", "1")
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// A closed stdout ends the run quietly: exit 0, nothing on stderr (docs/cli.md).
fn assert_ends_quietly(child: std::process::Child, what: &str) {
    let out = common::output_after_exit(child, what);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{what}: {err}");
    assert!(out.stderr.is_empty(), "{what}: {err}");
}

#[test]
fn a_closed_or_full_stdout_ends_cleanly() {
    // The reader is gone before the first line: that write fails with EPIPE, every time.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    assert_ends_quietly(endless_replay(writer), "replay into a closed pipe");
    // The reader leaves after one line, like `head -1`, while the output still comes: the
    // pipe cannot hold the rest, so a write after the close is certain.
    let mut child = endless_replay(Stdio::piped());
    let mut stdout = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut first = String::new();
    std::io::BufRead::read_line(&mut stdout, &mut first).unwrap();
    assert!(first.contains("seed 0:"), "{first:?}");
    drop(stdout);
    assert_ends_quietly(child, "replay | head -1");
    let full = Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(["env", "show", "--seed", "3"])
        .stdout(
            std::fs::OpenOptions::new()
                .write(true)
                .open("/dev/full")
                .unwrap(),
        )
        .output()
        .unwrap();
    assert_bad_input(&full, "standard output");
}

#[test]
fn unbounded_work_is_refused() {
    assert_bad_input(&gs(&["bench", "policy", "--secs", "inf"]), "--secs");
    assert_bad_input(
        &gs(&["bench", "policy", "--recurrence", "3"]),
        "--recurrence",
    );
    // Nothing to time is refused too, rather than reported as 0 steps/s.
    assert_bad_input(&gs(&["bench", "env", "--steps", "0"]), "--steps");
}

#[test]
fn replay_writes_all_outputs_or_none() {
    let tmp = tempfile::tempdir().unwrap();
    let rrd = tmp.path().join("x.rrd");
    let trace = tmp.path().join("t.json");
    let o = gs(&[
        "replay",
        "--seed",
        "1",
        "--save",
        rrd.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
        "--mcap",
        "/nonexistent/dir/x.mcap",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(entries(tmp.path()).is_empty(), "{:?}", entries(tmp.path()));
}

/// A reused output directory ends up holding the new run's outputs only: eval's figures and
/// `failures/` recordings, faithfulness's per-checkpoint figures; other files stay.
#[test]
fn a_reused_output_directory_keeps_no_earlier_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let o = out.to_str().unwrap();
    let small = [
        "--sizes",
        "8",
        "--objects",
        "4",
        "--seeds",
        "1",
        "--episodes",
        "3",
        "--quiet",
    ];
    // A sweep with failures to record (the 8×8 room's episodes all succeed, and only episodes
    // that failed or ground poorly are exported).
    let mut first = vec!["eval", "--out", o, "--export-failures", "--top-k", "2"];
    first.extend(crate::common::FAILING_SWEEP);
    assert_eq!(gs(&first).status.code(), Some(0));
    assert!(out.join("fig7_object_accuracy.png").exists());
    assert!(std::fs::read_dir(out.join("failures")).unwrap().count() > 0);
    std::fs::write(out.join("notes.txt"), b"mine").unwrap();
    let mut second = vec!["eval", "--out", o, "--checkpoint", "bundled:baseline"];
    second.extend(small);
    assert_eq!(gs(&second).status.code(), Some(0));
    assert!(
        !out.join("fig7_object_accuracy.png").exists(),
        "no stale attention figure"
    );
    assert!(!out.join("failures").exists(), "no stale recordings");
    assert!(
        out.join("notes.txt").exists(),
        "files it does not write are left alone"
    );

    let faith = dir.path().join("faith");
    let f = faith.to_str().unwrap();
    let fsmall = [
        "--seeds",
        "1",
        "--episodes",
        "2",
        "--quiet",
        "--parts",
        "steps",
    ];
    let mut two = vec![
        "faithfulness",
        "--out",
        f,
        "--checkpoint",
        "bundled:attention",
        "--checkpoint",
        "bundled:baseline",
    ];
    two.extend(fsmall);
    let r = gs(&two);
    assert_eq!(r.status.code(), Some(0), "{}", common::stderr(&r));
    assert!(faith.join("deletion_1.png").exists());
    let mut one = vec!["faithfulness", "--out", f];
    one.extend(fsmall);
    assert_eq!(gs(&one).status.code(), Some(0));
    assert!(faith.join("deletion.png").exists());
    assert!(!faith.join("deletion_1.png").exists() && !faith.join("deletion_0.png").exists());
}

/// Two trainings on one run directory: the second (new run or `--resume`) is refused naming
/// the first's pid, and the lock goes with the process that held it (SIGKILL included).
#[test]
fn a_run_directory_holds_one_training_at_a_time() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let r = run.to_str().unwrap();
    let mut first = Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(["train", "--out", r, "--quiet"])
        .args(TINY_RUN)
        .args(["--frames", "100000000", "--save-interval", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    common::wait_until("a checkpoint", || {
        assert!(first.try_wait().unwrap().is_none(), "the run ended");
        run.join("model.json").exists()
    });
    let pid = first.id().to_string();
    let mut args = vec!["train", "--out", r, "--quiet"];
    args.extend(TINY_RUN);
    args.extend(["--frames", "100000"]);
    let o = gs(&args);
    assert_bad_input(&o, &format!("another training (pid {pid})"));
    let o = gs(&["train", "--out", r, "--resume", "--quiet"]);
    assert_bad_input(&o, &format!("another training (pid {pid})"));
    first.kill().unwrap();
    first.wait().unwrap();
    let o = gs(&["train", "--out", r, "--resume", "--frames", "1", "--quiet"]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
}

/// A training refused because another holds the run directory touches nothing there, even
/// before the holder's first checkpoint: the holder keeps its logs and its lock (a later
/// training is still refused). The refused one used to "clean up" the holder's log.csv,
/// eval_log.csv and lock file as its own.
#[test]
fn a_refused_training_leaves_the_running_ones_files() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let r = run.to_str().unwrap();
    let mut first = Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(["train", "--out", r, "--quiet", "--eval-interval", "0"])
        .args(TINY_RUN)
        .args(["--frames", "100000000", "--save-interval", "1000000"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let rows =
        |run: &Path| std::fs::read_to_string(run.join("log.csv")).map_or(0, |t| t.lines().count());
    common::wait_until("a logged update", || {
        assert!(first.try_wait().unwrap().is_none(), "the run ended");
        rows(&run) > 1
    });
    let pid = first.id().to_string();
    let before = entries(&run);
    for _ in 0..2 {
        let mut args = vec!["train", "--out", r, "--quiet"];
        args.extend(TINY_RUN);
        args.extend(["--frames", "100000"]);
        let o = gs(&args);
        assert_bad_input(&o, &format!("another training (pid {pid})"));
        let o = gs(&["train", "--out", r, "--resume", "--quiet"]);
        assert_bad_input(&o, &format!("another training (pid {pid})"));
        assert_eq!(entries(&run), before, "the holder's files are all there");
    }
    let logged = rows(&run);
    common::wait_until("the holder logging on", || rows(&run) > logged);
    first.kill().unwrap();
    first.wait().unwrap();
}

/// `bench view` times each level in a process of its own and then puts them side by side;
/// the paper's level's episode is in by its first frame, BossLevel's (run to its step limit)
/// only later; a bad level is one line naming it.
#[test]
fn bench_view_times_each_level_and_puts_them_side_by_side() {
    let o = gs(&[
        "bench",
        "view",
        "--levels",
        "paper,BabyAI-BossLevel-v0",
        "--seed",
        "3",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 3, "a line per level and one side by side");
    let (paper, boss, both) = (&lines[0], &lines[1], &lines[2]);
    assert_eq!(
        (paper["level"].as_str(), boss["steps"].as_u64()),
        (Some("paper"), Some(1728))
    );
    assert_eq!(boss["checkpoint"], "bundled:babyai");
    for l in [paper, boss] {
        let first = l["time_to_first_frame_s"].as_f64().unwrap();
        let full = l["time_to_full_episode_s"].as_f64().unwrap();
        assert!(first > 0.0 && first <= full, "{l}");
        assert!(l["peak_rss_bytes"].as_u64().unwrap() > 1 << 20, "{l}");
    }
    assert_eq!(both["side_by_side"], true);
    assert_eq!(both["steps"], serde_json::json!([paper["steps"], 1728]));
    assert_eq!(
        both["peak_rss_bytes"],
        serde_json::json!([paper["peak_rss_bytes"], boss["peak_rss_bytes"]])
    );
    assert_bad_input(
        &gs(&["bench", "view", "--levels", "paper,BabyAI-Nope-v0"]),
        "BabyAI-Nope-v0",
    );
}

/// `bench view --walk-every-step` draws every step and says what the process holds as it
/// goes (issue #83): its resident memory, egui's live textures and the scenes kept.
#[test]
fn bench_view_walks_every_step_and_samples_what_the_process_holds() {
    let o = gs(&[
        "bench",
        "view",
        "--levels",
        "paper",
        "--seed",
        "3",
        "--walk-every-step",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    let line: serde_json::Value = serde_json::from_str(stdout.lines().next().unwrap()).unwrap();
    let steps = line["steps"].as_u64().unwrap();
    assert_eq!(line["walked_steps"].as_u64(), Some(steps), "{line}");
    let samples = line["walk_samples"].as_array().unwrap();
    assert!(
        !samples.is_empty() && samples.len() as u64 <= steps,
        "{line}"
    );
    assert_eq!(samples.last().unwrap()["step"].as_u64(), Some(steps - 1));
    for s in samples {
        assert!(s["rss_bytes"].as_u64().unwrap() > 1 << 20, "{s}");
        // The font atlas, and the world and view of the step shown at least.
        assert!(s["textures"].as_u64().unwrap() >= 3, "{s}");
        assert!(s["scenes_kept"].as_u64().unwrap() >= 1, "{s}");
    }
    assert!(line["walk_rss_growth_bytes_per_step"].is_number(), "{line}");
}
