//! Helpers shared by the integration tests.

#[cfg(feature = "app")]
pub mod debugger;
pub mod evals;
pub mod rrd;
pub mod tensors;
pub mod worlds;

use std::io::BufRead as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

/// How long a test waits for something that must happen (a file, a line, an exit) before it
/// fails: a guard against a hang, generous for a loaded machine, never what a test measures.
pub const GUARD: Duration = Duration::from_mins(2);

/// Polls `ready` (every millisecond) until it holds; fails naming `what` after [`GUARD`].
pub fn wait_until(what: &str, mut ready: impl FnMut() -> bool) {
    let deadline = Instant::now() + GUARD;
    while !ready() {
        assert!(Instant::now() < deadline, "waited {GUARD:?} for {what}");
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// Waits for `child` to exit; kills it and fails naming `what` after [`GUARD`].
pub fn wait_for_exit(child: &mut std::process::Child, what: &str) -> std::process::ExitStatus {
    let deadline = Instant::now() + GUARD;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if Instant::now() >= deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what} still runs after {GUARD:?}");
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// Runs groundscope with `args` and no input, failing after [`GUARD`] instead of hanging
/// (for inputs that used to make it wait forever).
pub fn gs_guarded(args: &[&str]) -> Output {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(args)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    output_after_exit(child, &format!("groundscope {args:?}"))
}

/// Waits for `child` as [`wait_for_exit`] does (failing naming `what` after [`GUARD`]), then
/// collects what it wrote to the pipes it was spawned with.
pub fn output_after_exit(mut child: std::process::Child, what: &str) -> Output {
    let status = wait_for_exit(&mut child, what);
    Output {
        status,
        ..child.wait_with_output().unwrap()
    }
}

/// Sends `SIG<signal>` (`"INT"`, `"TERM"`, …) to `child` with kill(1); fails if kill does.
pub fn send_signal(child: &std::process::Child, signal: &str) {
    let status = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success(), "kill -{signal}");
}

/// The lines of a child's output as they are printed, read on a thread until the pipe closes
/// (which also keeps the pipe from filling up).
pub fn lines(out: impl std::io::Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(out).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// The next line from [`lines`]; fails naming `what` if the pipe closes first or nothing comes
/// within [`GUARD`].
pub fn next_line(lines: &Receiver<String>, what: &str) -> String {
    lines
        .recv_timeout(GUARD)
        .unwrap_or_else(|e| panic!("no {what}: {e}"))
}

/// Runs the groundscope binary with `args` (one candle thread, as CI).
pub fn gs(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_groundscope"))
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .expect("the binary runs")
}

/// The rows of a CSV file, as header name → value maps.
pub fn csv_rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let header = r.headers().unwrap().clone();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            header
                .iter()
                .zip(rec.iter())
                .map(|(h, v)| (h.to_owned(), v.to_owned()))
                .collect()
        })
        .collect()
}

/// A command's standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A command's standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The names in `dir`, sorted.
pub fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Exit code 2 and a single `groundscope: …` line that mentions `what`.
pub fn assert_bad_input(o: &Output, what: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(
        err.starts_with("groundscope: ") && err.contains(what),
        "expected {what:?} in {err:?}"
    );
}

/// `tests/fixtures/onnx/<name>`: an ONNX fixture (made by `export/make_fixtures.sh`).
pub fn onnx_fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/onnx")
        .join(name)
}

/// The fixture files of `tests/fixtures/<set>`, sorted.
pub fn fixtures(set: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(set);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "json" || x == "gz"))
        .collect();
    files.sort();
    files
}

/// Runs `check` on every fixture of `set` and fails once, listing every failing file.
pub fn for_each_fixture(set: &str, check: impl Fn(&Path) -> Result<(), String>) -> usize {
    let files = fixtures(set);
    let n = files.len();
    let failures: Vec<String> = files
        .iter()
        .filter_map(|f| check(f).err().map(|e| format!("{}: {e}", f.display())))
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {n} fixtures failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
    n
}

/// A training run small enough to take milliseconds an update (S5N1, go to, 2 × 8 frames,
/// A one-seed sweep whose episodes include failures and poorly grounded ones (the bundled
/// attention model on S16N10, 12 episodes: 2 fail), so that `--export-failures` records some.
pub const FAILING_SWEEP: [&str; 8] = [
    "--sizes",
    "16",
    "--objects",
    "10",
    "--seeds",
    "1",
    "--episodes",
    "12",
];

/// hidden 8): flag and value pairs.
pub const TINY_RUN: [&str; 14] = [
    "--size",
    "5",
    "--objects",
    "1",
    "--tasks",
    "goto",
    "--procs",
    "2",
    "--frames-per-proc",
    "8",
    "--batch-size",
    "8",
    "--hidden",
    "8",
];

/// The smallest sweep `eval` and `faithfulness` run (one 8×8 room with 4 objects, one seed,
/// two episodes): flag and value pairs.
pub const SMALL_SWEEP: [&str; 8] = [
    "--sizes",
    "8",
    "--objects",
    "4",
    "--seeds",
    "1",
    "--episodes",
    "2",
];

/// `train --out DIR --quiet` with [`TINY_RUN`]'s flags, less those `extra` sets itself, then
/// `extra`.
pub fn train_tiny(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["train", "--out", dir.to_str().unwrap(), "--quiet"];
    for pair in TINY_RUN.chunks(2) {
        if !extra.contains(&pair[0]) {
            args.extend_from_slice(pair);
        }
    }
    args.extend_from_slice(extra);
    gs(&args)
}

/// A small PPO run on the paper's smallest level, with `extra` flags.
pub fn small_train<'a>(dir: &'a str, frames: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "train",
        "--model",
        "attention",
        "--out",
        dir,
        "--frames",
        frames,
        "--size",
        "5",
        "--objects",
        "1",
        "--tasks",
        "goto",
        "--no-done",
        "--procs",
        "4",
        "--hidden",
        "16",
        "--eval-interval",
        "0",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    args
}

/// [`small_train`] with 64-frame updates (4 × 16).
pub fn small_run<'a>(dir: &'a str, frames: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = small_train(
        dir,
        frames,
        &["--frames-per-proc", "16", "--batch-size", "32"],
    );
    args.extend_from_slice(extra);
    args
}

/// An untrained attention model of every word `level` can say, as `train --level` starts
/// from: enough to open any of its missions.
pub fn fresh_attention(level: groundscope::env::LevelConfig) -> groundscope::policy::Checkpoint {
    use groundscope::policy::{Checkpoint, ModelConfig, Params, TrainingState, Variant};
    let cfg = ModelConfig {
        vocab_size: ModelConfig::vocab_size_for(&level),
        ..ModelConfig::new(Variant::Attention)
    };
    Checkpoint::new(
        cfg,
        level,
        TrainingState::default(),
        Params::init(&cfg, 0).unwrap(),
    )
}

/// [`fresh_attention`] saved as `DIR/fresh`; its name, as the debugger is given it.
#[cfg(feature = "app")]
pub fn save_fresh_attention(dir: &Path, level: groundscope::env::LevelConfig) -> String {
    let name = dir.join("fresh");
    fresh_attention(level).save(&name).unwrap();
    name.to_str().unwrap().to_owned()
}
