//! PPO: learning on a tiny level, determinism, exact resume.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::format_collect,
    reason = "test helpers fail loudly"
)]

use groundscope::env::{LevelConfig, TaskSet};
use groundscope::episode::{ActionMode, EpisodeSpec, run_from};
use groundscope::policy::ppo::{PpoConfig, Trainer};
use groundscope::policy::{ModelConfig, Net, Params, Variant};

fn tiny_level() -> LevelConfig {
    LevelConfig {
        room_size: 5,
        n_objects: 1,
        tasks: TaskSet::GoTo,
        done_required: false,
        color_optional: false,
    }
}

fn small_model(variant: Variant) -> ModelConfig {
    ModelConfig {
        lstm_hidden: 32,
        gru_hidden: 32,
        head_hidden: 32,
        ..ModelConfig::new(variant)
    }
}

fn trainer(seed: u64, ppo: PpoConfig) -> Trainer {
    let model = small_model(Variant::Attention);
    Trainer::new(
        model,
        tiny_level(),
        ppo,
        Params::init(&model, seed).unwrap(),
        seed,
    )
    .unwrap()
}

fn small_ppo() -> PpoConfig {
    PpoConfig {
        procs: 8,
        frames_per_proc: 32,
        batch_size: 64,
        ..PpoConfig::default()
    }
}

#[test]
fn ppo_learns_the_tiny_level() {
    let mut t = trainer(1, small_ppo());
    for _ in 0..120 {
        t.update().unwrap();
    }
    let net = Net::new(t.model, t.params.detached());
    let mut successes = 0;
    for seed in 0..100 {
        let spec = EpisodeSpec {
            level: tiny_level(),
            seed,
            mission: None,
            mode: ActionMode::Greedy,
        };
        let world = tiny_level().generate(seed).unwrap();
        successes += usize::from(run_from(&net, "t", &spec, world).unwrap().success());
    }
    assert!(
        successes >= 80,
        "greedy success {successes}/100 after {} frames",
        t.state.frames
    );
}

#[test]
fn losses_are_deterministic_for_a_seed() {
    let ppo = PpoConfig {
        procs: 4,
        frames_per_proc: 16,
        batch_size: 32,
        ..PpoConfig::default()
    };
    let (mut a, mut b) = (trainer(5, ppo), trainer(5, ppo));
    for _ in 0..3 {
        let (la, lb) = (a.update().unwrap(), b.update().unwrap());
        assert_eq!(format!("{la:?}"), format!("{lb:?}"));
    }
    let mut c = trainer(6, ppo);
    assert_ne!(
        format!("{:?}", c.update().unwrap()),
        format!("{:?}", trainer(5, ppo).update().unwrap())
    );
}
