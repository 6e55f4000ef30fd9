//! The minigrid-style env the Python package steps (`env::gym::MinigridEnv`), tested here
//! without Python: a seeded reset is the level's generation for that seed, resets without a
//! seed continue the env's own generator deterministically, and the observation is written as
//! minigrid's `obs["image"]`.

use groundscope::env::gym::{IMAGE_BYTES, MinigridEnv};
use groundscope::env::{Action, LevelConfig};

fn world_key(env: &MinigridEnv) -> (String, (i32, i32), u8) {
    let w = env.world.as_ref().unwrap();
    (w.mission.clone(), w.agent_pos, w.agent_dir)
}

#[test]
fn seeded_resets_generate_the_level_and_unseeded_ones_continue_its_generator() {
    for id in [
        "BabyAI-GoToLocal-v0",
        "BabyAI-BossLevel-v0",
        "groundscope-PaperLocalS8N4-v0",
    ] {
        let level = LevelConfig::from_id(id).unwrap();
        let mut env = MinigridEnv::new(level);
        assert!(
            env.step(Action::Forward)
                .unwrap_err()
                .to_string()
                .contains("reset()")
        );
        env.reset(Some(5), || unreachable!("seeded")).unwrap();
        let want = level.generate(5).unwrap();
        let got = env.world.as_ref().unwrap();
        assert_eq!(
            (&got.mission, got.agent_pos, got.agent_dir),
            (&want.mission, want.agent_pos, want.agent_dir),
            "{id}"
        );
        // The observation as minigrid writes it: the image x-major, then the direction.
        let mut image = vec![0u8; IMAGE_BYTES];
        let dir = env.write_obs(&mut image);
        let obs = want.observe();
        let flat: Vec<u8> = obs.image.iter().flatten().flatten().copied().collect();
        assert_eq!(image, flat, "{id}");
        assert_eq!(dir, want.agent_dir);
        // Resets without a seed continue the generator: new levels, the same for two envs
        // seeded alike.
        let mut twin = MinigridEnv::new(level);
        twin.reset(Some(5), || 0).unwrap();
        let first = world_key(&env);
        for _ in 0..3 {
            env.reset(None, || unreachable!("seeded before")).unwrap();
            twin.reset(None, || unreachable!("seeded before")).unwrap();
            assert_eq!(world_key(&env), world_key(&twin), "{id}");
        }
        assert_ne!(
            world_key(&env),
            first,
            "{id}: the generator did not move on"
        );
        env.step(Action::Left).unwrap();
        assert_eq!(env.world.as_ref().unwrap().step_count, 1);
    }
}

/// A first reset without a seed seeds the generator with what the caller draws (gymnasium:
/// the OS's entropy): the same as a reset with that seed.
#[test]
fn an_unseeded_first_reset_takes_the_callers_seed() {
    let level = LevelConfig::from_id("BabyAI-GoToLocal-v0").unwrap();
    let mut a = MinigridEnv::new(level);
    a.reset(None, || 42).unwrap();
    let mut b = MinigridEnv::new(level);
    b.reset(Some(42), || unreachable!()).unwrap();
    assert_eq!(world_key(&a), world_key(&b));
    assert_eq!(a.mission(), b.mission());
}
