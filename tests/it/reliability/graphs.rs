//! Hostile imported graphs and interrupted sweeps (issue #43): a graph groundscope cannot run
//! safely (an opset outside tract's range, an empty file, NaN or negative outputs, allocation
//! bombs) is refused in one line with exit 2 by every command that loads it, and Ctrl-C
//! during `eval` or `faithfulness` says what was kept, exits 130 and leaves `--out` as it was.

use crate::common::{self, SMALL_SWEEP, assert_bad_input, entries, gs, gs_guarded, onnx_fixture};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Graphs groundscope's ONNX runtime cannot run safely are refused by name before tract sees
/// them: an opset outside tract's tested range (tract panicked on opset 99), an empty file;
/// a graph that computes NaN is refused at its first step instead of writing `null`s.
#[test]
fn hostile_graphs_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = std::fs::read(common::onnx_fixture("minimal.onnx")).unwrap();
    // opset_import { domain: "", version: 17 } → version 99
    let at = bytes
        .windows(6)
        .position(|w| w == [0x42, 0x04, 0x0a, 0x00, 0x10, 0x11])
        .expect("minimal.onnx imports opset 17");
    bytes[at + 5] = 99;
    let future = dir.path().join("future.onnx");
    std::fs::write(&future, &bytes).unwrap();
    for cmd in [vec!["replay", "--checkpoint"], vec!["validate"]] {
        let mut args = cmd.clone();
        args.push(future.to_str().unwrap());
        assert_bad_input(&gs(&args), "ONNX opset 99 is outside");
    }
    let empty = dir.path().join("empty.onnx");
    std::fs::write(&empty, b"").unwrap();
    assert_bad_input(
        &gs(&["replay", "--checkpoint", empty.to_str().unwrap()]),
        "empty",
    );
    replay_is_refused(&common::onnx_fixture("bad_nan.onnx"), dir.path(), "NaN");
}

/// `replay --checkpoint graph --trace <dir>/t.json` is refused naming `what` and writes no
/// trace; returns the output for any further checks.
fn replay_is_refused(graph: &Path, dir: &Path, what: &str) -> std::process::Output {
    let trace = dir.join("t.json");
    let o = gs(&[
        "replay",
        "--checkpoint",
        graph.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_bad_input(&o, what);
    assert!(!trace.exists(), "no trace written");
    o
}

/// `train --init` names why a graph cannot seed training.
#[test]
fn a_graph_cannot_seed_training() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let graph = common::onnx_fixture("minimal.onnx");
    let o = gs(&[
        "train",
        "--model",
        "attention",
        "--out",
        run.to_str().unwrap(),
        "--init",
        graph.to_str().unwrap(),
    ]);
    assert_bad_input(&o, "an ONNX graph cannot seed training");
    assert!(!run.exists());
}

/// The commands that load a graph, each writing into `dir` where it writes at all.
fn loaders(graph: &str, dir: &Path) -> Vec<Vec<String>> {
    let out = |n: &str| dir.join(n).to_str().unwrap().to_owned();
    let mut eval = vec!["eval", "--quiet", "--checkpoint", graph, "--out"];
    let eval_out = out("eval");
    eval.push(&eval_out);
    eval.extend(SMALL_SWEEP);
    let faith_out = out("faith");
    let mut faith = vec!["faithfulness", "--quiet", "--checkpoint", graph, "--out"];
    faith.push(&faith_out);
    faith.extend(SMALL_SWEEP);
    let trace = out("t.json");
    let replay = vec!["replay", "--checkpoint", graph, "--trace", &trace];
    [replay, eval, faith]
        .into_iter()
        .map(|v| v.into_iter().map(str::to_owned).collect())
        .collect()
}

/// Runs groundscope under a 16 GB address-space limit: should a bound ever stop working,
/// the bomb fails its allocation here instead of taking the machine's memory.
fn gs_limited(args: &[String]) -> std::process::Output {
    let child = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 16000000; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_groundscope"))
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    common::output_after_exit(child, &format!("groundscope {args:?}"))
}

/// A graph that asks for a 30 GB or 150 GB tensor is refused before anything is allocated:
/// one line naming the node and its shape, exit 2, no output; before the bound tract panicked
/// ("failed to allocate", and in `eval` "a scoped thread panicked") or was killed for memory.
#[test]
fn allocation_bombs_are_refused_naming_the_node_and_shape() {
    for (file, what) in [
        (
            "bad_expand_bomb.onnx",
            "node \"expand_bomb\" computes a tensor of shape (B, 8, 1000000000)",
        ),
        (
            "bad_constant_bomb.onnx",
            "node \"constant_bomb\" (ConstantOfShape) makes a tensor of shape (200000, 200000)",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let graph = onnx_fixture(file);
        for args in loaders(graph.to_str().unwrap(), dir.path()) {
            let o = gs_limited(&args);
            assert_bad_input(&o, what);
            assert!(
                common::stderr(&o).contains("1 GiB"),
                "{file} {args:?}: the bound is named"
            );
            assert!(
                entries(dir.path()).is_empty(),
                "{file} {}: left {:?}",
                args[0],
                entries(dir.path())
            );
        }
        // `view` under a virtual display, as a headless user runs it: refused before the
        // window opens (it used to hang once its background worker had panicked).
        let shot = dir.path().join("shot.png");
        let child = Command::new("xvfb-run")
            .args([
                "-a",
                env!("CARGO_BIN_EXE_groundscope"),
                "view",
                "--checkpoint",
            ])
            .arg(&graph)
            .arg("--screenshot")
            .arg(&shot)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn();
        match child {
            Ok(child) => {
                let o = common::output_after_exit(child, "xvfb-run groundscope view");
                assert_bad_input(&o, what);
                assert!(!shot.exists(), "{file}: no screenshot");
            }
            Err(e) => eprintln!("skipped view: xvfb-run: {e}"),
        }
    }
}

/// A tensor that fits one row but not a batch (4 MB a row) runs in `replay` (one episode)
/// and is refused by `eval` before the step whose batch would take it over 1 GiB, naming the
/// batch size: the bound is checked again for every batch size a step runs with.
#[test]
fn a_tensor_too_large_for_the_batch_is_refused_at_that_batch() {
    let dir = tempfile::tempdir().unwrap();
    let graph = onnx_fixture("bad_batch_bomb.onnx");
    let graph = graph.to_str().unwrap();
    let o = gs(&["replay", "--checkpoint", graph]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let out = dir.path().join("report");
    let o = gs_limited(
        &[
            "eval",
            "--quiet",
            "--checkpoint",
            graph,
            "--out",
            out.to_str().unwrap(),
            "--sizes",
            "8",
            "--objects",
            "4",
            "--seeds",
            "1",
            "--episodes",
            "1000",
        ]
        .map(str::to_owned),
    );
    assert_bad_input(
        &o,
        "node \"batch_bomb\" computes a tensor of shape (B, 1, 1000000)",
    );
    assert!(common::stderr(&o).contains("at B = "), "{o:?}");
    assert!(!out.exists(), "no report");
}

/// Negative attention is refused where it is computed, naming the output and the step, as
/// NaN is: nothing is drawn, measured or written from it.
#[test]
fn negative_word_maps_are_refused_naming_the_step() {
    let dir = tempfile::tempdir().unwrap();
    let graph = onnx_fixture("bad_negative_maps.onnx");
    let o = replay_is_refused(&graph, dir.path(), "output word_maps holds -");
    assert!(common::stderr(&o).contains("at step 0 of"), "{o:?}");
    let out = dir.path().join("report");
    let mut args = vec![
        "eval",
        "--quiet",
        "--checkpoint",
        graph.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(SMALL_SWEEP);
    let o = gs(&args);
    assert_bad_input(&o, "output word_maps holds -");
    assert!(!out.exists(), "no report of negative maps");
}

/// Sends SIGINT to `child` once it has run `after`.
fn interrupt(child: &std::process::Child, after: Duration) {
    std::thread::sleep(after);
    common::send_signal(child, "INT");
}

/// A sweep far longer than the test: 4 room sizes × 5 seeds × 1000 episodes.
const BIG: [&str; 10] = [
    "--sizes",
    "8,10,12,14",
    "--objects",
    "4",
    "--seeds",
    "5",
    "--episodes",
    "1000",
    "--jobs",
    "2",
];

/// Ctrl-C during `eval` exits 130 with one line saying nothing was written, removes what it
/// staged and leaves an earlier report in `--out` byte for byte; `faithfulness` too, and a
/// `--out` it created is gone again.
#[test]
fn ctrl_c_during_a_sweep_keeps_the_earlier_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let o = out.to_str().unwrap();
    let mut args = vec!["eval", "--quiet", "--out", o];
    args.extend(SMALL_SWEEP);
    let first = gs(&args);
    assert_eq!(first.status.code(), Some(0), "{}", common::stderr(&first));
    let before = std::fs::read(out.join("report.json")).unwrap();
    let names = entries(&out);

    let faith_out = dir.path().join("faith");
    for (cmd, target) in [("eval", &out), ("faithfulness", &faith_out)] {
        let mut args = vec![cmd, "--quiet", "--out", target.to_str().unwrap()];
        args.extend(BIG);
        let child = Command::new(env!("CARGO_BIN_EXE_groundscope"))
            .args(&args)
            .env("RAYON_NUM_THREADS", "1")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        interrupt(&child, Duration::from_secs(1));
        let got = common::output_after_exit(child, cmd);
        let status = got.status;
        let err = String::from_utf8_lossy(&got.stderr);
        assert_eq!(status.code(), Some(130), "{cmd}: {status:?} {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{cmd}: one line: {err}");
        assert!(
            err.starts_with("groundscope: interrupted: nothing was written;")
                && err.contains("is as it was"),
            "{cmd}: {err}"
        );
    }
    assert_eq!(entries(&out), names, "no staging directory left in --out");
    assert_eq!(std::fs::read(out.join("report.json")).unwrap(), before);
    assert!(
        !faith_out.exists(),
        "faithfulness made --out, and removed it"
    );
    // Still usable afterwards: the next run is not blocked by anything left behind.
    let again = gs_guarded(&[
        "faithfulness",
        "--quiet",
        "--out",
        faith_out.to_str().unwrap(),
        "--sizes",
        "8",
        "--objects",
        "4",
        "--seeds",
        "1",
        "--episodes",
        "1",
        "--parts",
        "steps",
    ]);
    assert_eq!(again.status.code(), Some(0), "{}", common::stderr(&again));
}
