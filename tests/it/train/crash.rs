//! Crash consistency of training runs: a run killed with SIGKILL at any instant (during an
//! update, a save, or start-up) resumes, and a reader of `RUN/model` never sees a
//! half-written checkpoint while the run rewrites it. The kills are timed by what the run
//! shows (a line, a log row, a change in its checkpoints), not by delays.

use crate::common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Instant;

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
    cmd.stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn updates_of(dir: &Path) -> u64 {
    let ckpt = Checkpoint::load(&dir.join("model")).unwrap();
    ckpt.meta.training.updates
}

/// The names in `RUN/checkpoints` (none before the first save).
fn checkpoint_entries(dir: &Path) -> Vec<String> {
    if dir.join("checkpoints").is_dir() {
        common::entries(&dir.join("checkpoints"))
    } else {
        Vec::new()
    }
}

/// The newest generation, `RUN/checkpoints/update-N`.
fn newest_generation(dir: &Path) -> Option<u64> {
    checkpoint_entries(dir)
        .iter()
        .filter_map(|n| n.strip_prefix("update-")?.parse().ok())
        .max()
}

/// The update of the last row of `RUN/log.csv`.
fn last_logged(dir: &Path) -> Option<u64> {
    let log = std::fs::read_to_string(dir.join("log.csv")).ok()?;
    log.lines().skip(1).last()?.split(',').next()?.parse().ok()
}

/// What a kill waits for: each puts it at another point of a run's life.
#[derive(Clone, Copy, Debug)]
enum KillAt {
    /// A generation newer than any at the spawn has landed: the run is publishing
    /// `RUN/model` and pruning old generations, or has gone on to the next update.
    NewGeneration,
    /// Nothing: start-up, or a resume reading its generation.
    Spawn,
    /// The run's first line on stdout: start-up is over, the first update runs.
    Started,
    /// `RUN/checkpoints` changes: a save has begun (its temporary generation appears).
    SaveBegins,
    /// `log.csv` has a row past every update the run had logged or saved at the spawn: an
    /// update is done and its save comes next.
    Logged,
}

#[test]
fn sigkill_at_any_point_always_leaves_a_run_that_resumes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let order = [
        KillAt::NewGeneration,
        KillAt::Spawn,
        KillAt::Started,
        KillAt::SaveBegins,
        KillAt::Logged,
    ];
    for i in 0..30 {
        let kill_at = order[i % order.len()];
        // The first run starts the directory; every kill after it must leave a generation.
        let generation = newest_generation(&dir);
        assert_eq!(
            generation.is_some(),
            i > 0,
            "kill {i}: a kill left no generation to resume from"
        );
        let (listing, logged) = (checkpoint_entries(&dir), last_logged(&dir));
        let mut child = start(&dir, 1 << 40, i > 0);
        let stdout = common::lines(child.stdout.take().unwrap());
        let mut running = || {
            if let Some(status) = child.try_wait().unwrap() {
                let mut err = String::new();
                std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
                panic!("kill {i} ({kill_at:?}): the run ended by itself ({status}): {err}");
            }
        };
        let past = generation.max(logged);
        match kill_at {
            KillAt::Spawn => {}
            KillAt::Started => {
                let line = common::next_line(&stdout, "first line of the run");
                assert!(line.starts_with("training "), "{line}");
            }
            KillAt::NewGeneration => common::wait_until("a new generation", || {
                running();
                newest_generation(&dir) > generation
            }),
            KillAt::SaveBegins => common::wait_until("a save", || {
                running();
                checkpoint_entries(&dir) != listing
            }),
            KillAt::Logged => common::wait_until("a new row in log.csv", || {
                running();
                last_logged(&dir) > past
            }),
        }
        child.kill().unwrap();
        child.wait().unwrap();
        if dir.join("model.json").exists() {
            // Whatever instant the kill hit, the published checkpoint loads.
            updates_of(&dir);
        }
    }
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
    common::wait_until("the first save", || dir.join("model.json").exists());
    // Read as fast as possible until the run has rewritten the checkpoint under the reader
    // twenty times (seen as twenty different update counts).
    let (mut loads, mut updates) = (0, std::collections::BTreeSet::new());
    let mut failures = Vec::new();
    let deadline = Instant::now() + common::GUARD;
    while failures.is_empty() && (loads < 100 || updates.len() < 20) {
        assert!(
            Instant::now() < deadline,
            "{loads} reads saw only {updates:?} in {:?}",
            common::GUARD
        );
        assert!(child.try_wait().unwrap().is_none(), "the run ended");
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
        "a read failed after {loads}: {failures:?}"
    );
}
