//! A run's one front door (issue #80): `RunSpec::default` is the one list of a run's
//! defaults, `Run::create` checks the whole spec before it touches the disk (imitation's
//! labels included), a resume's differences name the settings that changed, and every
//! refusal is a `RunError` variant a front end matches rather than a message it parses.

use std::path::Path;

use groundscope::env::LevelConfig;
use groundscope::policy::ppo::PpoConfig;
use groundscope::policy::{ModelConfig, Variant};
use groundscope::run::{Difference, Run, RunDir, RunError, RunSpec, Start, Tracking};

/// A new run of one small update (64 frames) on the paper's level at S = 5, N = 1.
fn small(seed: u64) -> RunSpec {
    RunSpec {
        start: Start::New {
            model: small_model(),
            levels: small_level().into(),
            ppo: small_ppo(),
            seed,
        },
        frames: 64,
        tracking: Tracking {
            eval_interval: 0,
            eval_episodes: 1,
            save_interval: Some(1),
        },
        teachers: Vec::new(),
    }
}

fn small_model() -> ModelConfig {
    ModelConfig {
        lstm_hidden: 16,
        gru_hidden: 16,
        ..ModelConfig::new(Variant::Attention)
    }
}

fn small_level() -> LevelConfig {
    LevelConfig {
        room_size: 5,
        n_objects: 1,
        ..LevelConfig::default()
    }
}

fn small_ppo() -> PpoConfig {
    PpoConfig {
        procs: 4,
        frames_per_proc: 16,
        batch_size: 32,
        ..PpoConfig::default()
    }
}

/// Trains `spec` in `path` to its frames and saves it.
fn train(path: &Path, spec: RunSpec) {
    let mut run = Run::create(path, spec).unwrap();
    while !run.done() {
        run.update().unwrap();
    }
    run.finish().unwrap();
}

/// The invalid setting `Run::create` refuses `spec` with, the directory left unmade.
fn refused_field(spec: RunSpec) -> (&'static str, String) {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("run");
    match Run::create(&path, spec).err().expect("refused") {
        RunError::Invalid { field, reason } => {
            assert!(!path.exists(), "{field}: the directory was made");
            (field, reason)
        }
        e => panic!("not an invalid setting: {e}"),
    }
}

#[test]
fn the_default_spec_is_the_list_of_a_runs_defaults() {
    let d = RunSpec::default();
    assert_eq!(d.frames, 5_000_000);
    assert_eq!(
        d.tracking,
        Tracking {
            eval_interval: 50,
            eval_episodes: 200,
            save_interval: Some(10),
        }
    );
    assert_eq!(d.start.seed(), 1);
    assert_eq!(d.start.model().variant, Variant::Attention);
    assert_eq!(d.start.model().lstm_hidden, 128);
    assert_eq!(*d.start.ppo(), PpoConfig::default());
    assert_eq!(d.start.levels().first(), LevelConfig::default());
    // The default spec is one a run can start from.
    assert!(d.check().unwrap().is_empty());
}

#[test]
fn differences_name_each_changed_setting_and_none_for_the_runs_own() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("run");
    train(&path, small(3));
    let resumable = Run::resume(&path).unwrap();
    let info = resumable.info();
    assert!(
        info.differences(&small(3)).is_empty(),
        "{:?}",
        info.differences(&small(3))
    );
    // Frames and tracking are not kept against the caller.
    let later = RunSpec {
        frames: 640,
        tracking: Tracking::default(),
        ..small(3)
    };
    assert!(info.differences(&later).is_empty());
    let faster = RunSpec {
        start: Start::New {
            model: small_model(),
            levels: small_level().into(),
            ppo: PpoConfig {
                lr: 0.5,
                ..small_ppo()
            },
            seed: 3,
        },
        ..small(3)
    };
    assert_eq!(
        info.differences(&faster),
        [Difference {
            field: "lr",
            stored: "0.001".into(),
            given: "0.5".into(),
        }]
    );
    let other = RunSpec {
        start: Start::New {
            model: ModelConfig {
                lstm_hidden: 32,
                gru_hidden: 32,
                ..ModelConfig::new(Variant::Baseline)
            },
            levels: LevelConfig {
                color_optional: false,
                ..small_level()
            }
            .into(),
            ppo: small_ppo(),
            seed: 4,
        },
        ..small(3)
    };
    let fields: Vec<&str> = info.differences(&other).iter().map(|d| d.field).collect();
    for field in ["variant", "hidden", "seed", "color_optional"] {
        assert!(fields.contains(&field), "{field} in {fields:?}");
    }
    assert_eq!(fields[0], "variant", "the model variant comes first");
    assert!(!fields.contains(&"lr"), "{fields:?}");
}

#[test]
fn a_held_directory_a_run_over_a_run_and_nothing_to_resume_are_their_own_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("run");
    train(&path, small(3));
    // A new run over the one the directory holds.
    assert!(matches!(
        Run::create(&path, small(3)).err(),
        Some(RunError::Occupied(dir)) if dir == path
    ));
    // A second training while this one holds the directory, naming this process.
    let resumable = Run::resume(&path).unwrap();
    match RunDir::open(&path, false).err().expect("the lock is held") {
        RunError::Held { dir, pid } => {
            assert_eq!(dir, path);
            assert_eq!(pid, std::process::id().to_string());
        }
        e => panic!("not held: {e}"),
    }
    assert!(matches!(
        Run::resume(&path).err(),
        Some(RunError::Held { .. })
    ));
    drop(resumable);
    // A directory with no checkpoint (a run stopped before its first save).
    let empty = tmp.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    std::fs::write(empty.join("log.csv"), groundscope::run::LOG_HEADER).unwrap();
    assert!(matches!(
        Run::resume(&empty).err(),
        Some(RunError::NothingToResume(dir)) if dir == empty
    ));
}

#[test]
fn create_refuses_an_invalid_setting_by_name_before_it_touches_the_disk() {
    let bad_ppo = RunSpec {
        start: Start::New {
            model: small_model(),
            levels: small_level().into(),
            ppo: PpoConfig {
                procs: 0,
                ..small_ppo()
            },
            seed: 1,
        },
        ..small(1)
    };
    assert_eq!(refused_field(bad_ppo).0, "ppo");
    let never_saved = RunSpec {
        tracking: Tracking {
            save_interval: Some(0),
            ..Tracking::default()
        },
        ..small(1)
    };
    assert_eq!(refused_field(never_saved).0, "save_interval");
    let frozen_baseline = RunSpec {
        start: Start::New {
            model: ModelConfig {
                lstm_hidden: 16,
                gru_hidden: 16,
                ..ModelConfig::new(Variant::Baseline)
            },
            levels: small_level().into(),
            ppo: PpoConfig {
                freeze_attention_at: Some(64),
                ..small_ppo()
            },
            seed: 1,
        },
        ..small(1)
    };
    assert_eq!(refused_field(frozen_baseline).0, "freeze_attention_at");
}

#[test]
fn create_refuses_imitation_on_a_level_the_bot_cannot_label() {
    let key_in_box = LevelConfig::from_id("BabyAI-KeyInBox-v0").unwrap();
    let spec = RunSpec {
        start: Start::New {
            model: small_model(),
            levels: key_in_box.into(),
            ppo: PpoConfig {
                imitate: true,
                ..small_ppo()
            },
            seed: 1,
        },
        ..small(1)
    };
    let (field, reason) = refused_field(spec);
    assert_eq!(field, "imitate");
    assert!(reason.contains("BabyAI-KeyInBox-v0"), "{reason}");
    assert!(reason.contains("no labelled frame"), "{reason}");
}

/// The bot labels MiniGrid's ids rewarded for one pickup (it is given the pickup instruction
/// of the target), so imitation on KeyCorridor is not refused; DoorKey's goal it does not
/// plan: beside KeyCorridor that level is named in the warning with nothing labelled, alone
/// it is refused.
#[test]
fn imitation_labels_minigrids_pickup_ids() {
    use groundscope::policy::ppo::LevelMix;
    use groundscope::run::check_labels;
    let kc = LevelMix::parse("MiniGrid-KeyCorridorS3R1-v0", false).unwrap();
    assert_eq!(check_labels(&kc).unwrap(), Vec::<String>::new());
    let both =
        LevelMix::parse("MiniGrid-KeyCorridorS3R1-v0,MiniGrid-DoorKey-5x5-v0", false).unwrap();
    let silent = check_labels(&both).unwrap();
    assert_eq!(silent.len(), 1, "{silent:?}");
    assert!(
        silent[0].starts_with("MiniGrid-DoorKey-5x5-v0 (0 of "),
        "{silent:?}"
    );
    let door_key = LevelMix::parse("MiniGrid-DoorKey-5x5-v0", false).unwrap();
    match check_labels(&door_key) {
        Err(RunError::Invalid { field, reason }) => {
            assert_eq!(field, "imitate");
            assert!(reason.contains("MiniGrid-DoorKey-5x5-v0"), "{reason}");
        }
        other => panic!("not refused: {other:?}"),
    }
}
