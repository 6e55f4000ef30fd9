//! Crash consistency of training runs: a run killed with SIGKILL at any instant (during an
//! update, a save, or start-up) resumes, and a reader of `RUN/model` never sees a
//! half-written checkpoint while the run rewrites it.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test helpers fail loudly"
)]

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use groundscope::policy::Checkpoint;

/// A tiny run that saves after every update, so kills land inside saves often.
fn start(dir: &Path, frames: u64, resume: bool) -> Child {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_groundscope"));
    cmd.args([
        "train",
        "--out",
        dir.to_str().unwrap(),
        "--frames",
        &frames.to_string(),
    ])
    .args(common::TINY_RUN)
    .args([
        "--save-interval",
        "1",
        "--eval-interval",
        "3",
        "--eval-episodes",
        "2",
        "--quiet",
    ]);
    if resume {
        cmd.arg("--resume");
    }
    cmd.stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn updates_of(dir: &Path) -> u64 {
    let ckpt = Checkpoint::load(&dir.join("model")).unwrap();
    ckpt.meta.training.updates
}

#[test]
fn sigkill_at_random_instants_always_leaves_a_run_that_resumes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    // A fixed pseudo-random sequence of delays from 0 to 400 ms: start-up, updates and saves.
    let mut x: u64 = 0x2545_F491_4F6C_DD1D;
    let mut resumed = 0;
    for _ in 0..30 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let delay = Duration::from_millis(x % 400);
        let has_run = std::fs::read_dir(dir.join("checkpoints")).is_ok_and(|mut d| {
            d.any(|e| {
                e.unwrap()
                    .file_name()
                    .to_string_lossy()
                    .starts_with("update-")
            })
        });
        let mut child = start(&dir, 1 << 40, has_run);
        std::thread::sleep(delay);
        if let Ok(Some(status)) = child.try_wait() {
            let mut err = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
            panic!("the run ended by itself ({status}): {err}");
        }
        child.kill().unwrap();
        child.wait().unwrap();
        resumed += usize::from(has_run);
        if dir.join("model.json").exists() {
            // Whatever instant the kill hit, the published checkpoint loads.
            updates_of(&dir);
        }
    }
    assert!(resumed >= 20, "only {resumed} kills hit a resumed run");
    // The run finishes normally from wherever the kills left it.
    let before = updates_of(&dir);
    let target = (before + 2) * 16;
    let out = start(&dir, target, true).wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(updates_of(&dir), before + 2);
    let log = std::fs::read_to_string(dir.join("log.csv")).unwrap();
    let rows: Vec<u64> = log
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(
        rows,
        (1..=before + 2).collect::<Vec<_>>(),
        "one log row per update, none twice"
    );
    let gens = std::fs::read_dir(dir.join("checkpoints")).unwrap().count();
    assert!(gens <= 3, "{gens} entries: old generations are pruned");
}

#[test]
fn readers_never_see_a_checkpoint_being_rewritten() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let mut child = start(&dir, 1 << 40, false);
    let model = dir.join("model");
    let deadline = Instant::now() + Duration::from_secs(20);
    while !dir.join("model.json").exists() {
        assert!(Instant::now() < deadline, "the run never saved");
        std::thread::sleep(Duration::from_millis(5));
    }
    let (mut loads, mut updates) = (0, std::collections::BTreeSet::new());
    let until = Instant::now() + Duration::from_secs(4);
    let mut failures = Vec::new();
    while Instant::now() < until {
        match Checkpoint::load(&model) {
            Ok(c) => {
                loads += 1;
                updates.insert(c.meta.training.updates);
            }
            Err(e) => failures.push(e.to_string()),
        }
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        failures.is_empty(),
        "{} failed reads: {failures:?}",
        failures.len()
    );
    assert!(loads >= 20, "only {loads} reads");
    assert!(
        updates.len() >= 5,
        "the run saved only {updates:?} while being read"
    );
}
