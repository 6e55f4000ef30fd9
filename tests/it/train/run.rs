//! The training run as a core object (`groundscope::run`, issue #67): a caller without the
//! command line starts, steps, finishes and resumes a run, and a new run that fails before its
//! first checkpoint leaves nothing behind.

use groundscope::env::LevelConfig;
use groundscope::policy::ppo::PpoConfig;
use groundscope::policy::{ModelConfig, Variant};
use groundscope::run::{Run, RunDir, RunSpec, Start, Tracking};

fn small() -> (ModelConfig, LevelConfig, PpoConfig) {
    let model = ModelConfig {
        lstm_hidden: 16,
        gru_hidden: 16,
        ..ModelConfig::new(Variant::Attention)
    };
    let level = LevelConfig {
        room_size: 5,
        n_objects: 1,
        ..LevelConfig::default()
    };
    let ppo = PpoConfig {
        procs: 4,
        frames_per_proc: 16,
        batch_size: 32,
        ..PpoConfig::default()
    };
    (model, level, ppo)
}

fn tracking() -> Tracking {
    Tracking {
        eval_interval: 2,
        eval_episodes: 2,
        save_interval: Some(2),
    }
}

#[test]
fn a_run_starts_steps_finishes_and_resumes_without_the_command_line() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("run");
    let (model, level, ppo) = small();
    let spec = RunSpec {
        start: Start::New {
            model,
            levels: level.into(),
            ppo,
            seed: 3,
        },
        frames: 192,
        tracking: tracking(),
        teachers: Vec::new(),
    };
    let mut run = Run::start(RunDir::open(&path, true).unwrap(), spec).unwrap();
    let mut evals = 0;
    while !run.done() {
        let p = run.update().unwrap();
        assert!(p.fps > 0.0);
        evals += p.evals.len();
    }
    assert_eq!(evals, 1, "one tracked evaluation, at update 2");
    let last = run.finish().unwrap().expect("three updates ran");
    assert_eq!(last.update, 3);
    let log = std::fs::read_to_string(path.join("log.csv")).unwrap();
    assert_eq!(log.lines().count(), 4, "{log}");
    assert_eq!(
        std::fs::read_to_string(path.join("eval_log.csv"))
            .unwrap()
            .lines()
            .count(),
        2
    );
    // A second run of the directory while it is held is refused naming the holder.
    let held = RunDir::open(&path, false).unwrap();
    let again = RunDir::open(&path, false).err().expect("the lock is held");
    assert!(again.to_string().contains("another training"), "{again:#}");
    // The resume goes on from the checkpoint, keeping the log rows it holds.
    let (trainer, info) = held.load().unwrap();
    assert_eq!(trainer.state.updates, 3);
    assert_eq!(info.seed, 3);
    let spec = RunSpec {
        start: Start::Resume {
            trainer: Box::new(trainer),
            info: Box::new(info),
        },
        frames: 256,
        tracking: tracking(),
        teachers: Vec::new(),
    };
    let mut run = Run::start(held, spec).unwrap();
    while !run.done() {
        run.update().unwrap();
    }
    run.finish().unwrap();
    let log = std::fs::read_to_string(path.join("log.csv")).unwrap();
    let updates: Vec<&str> = log
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(updates, ["1", "2", "3", "4"]);
}

#[test]
fn a_new_run_that_fails_before_its_first_checkpoint_leaves_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("fails");
    let (model, level, ppo) = small();
    // A start that fails after the directory is locked: an invalid PPO setting reaches the
    // trainer.
    let spec = RunSpec {
        start: Start::New {
            model,
            levels: level.into(),
            ppo: PpoConfig { procs: 0, ..ppo },
            seed: 1,
        },
        frames: 64,
        tracking: tracking(),
        teachers: Vec::new(),
    };
    let dir = RunDir::open(&path, true).unwrap();
    assert!(path.exists());
    assert!(Run::start(dir, spec).is_err());
    assert!(!path.exists(), "the directory it made is gone");
    // In a directory that was there, only what the run made goes: the user's file stays.
    std::fs::create_dir_all(&path).unwrap();
    std::fs::write(path.join("notes.txt"), "mine").unwrap();
    let dir = RunDir::open(&path, true).unwrap();
    drop(dir);
    let left: Vec<String> = std::fs::read_dir(&path)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, ["notes.txt"]);
}
