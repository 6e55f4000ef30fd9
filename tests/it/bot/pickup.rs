//! minigrid's bot on MiniGrid's own environments rewarded for picking up one object
//! (`Rules::Pickup`: KeyCorridor, UnlockPickup, BlockedUnlockPickup, ObstructedMaze), given
//! BabyAI's `pick up the <color> <kind>` of that object: it solves those whose keys lie on the
//! floor, gives up (never hangs) on those whose keys are in boxes, labels what `label_share`
//! reports, heads for the very object MiniGrid rewards, and stays no expert on every other rule.

use crate::common::worlds::babyai;
use groundscope::bot::{Expert, NO_EXPERT, label_share, plans};
use groundscope::env::minigrid::Rules;
use groundscope::env::{LevelConfig, LevelId, World};

/// One episode of the bot alone, as `label_share` runs it.
#[derive(Debug, Default)]
struct Alone {
    /// Steps it advised (and took).
    labelled: u64,
    /// Where it gave up: the steps left to the horizon.
    left: Option<u64>,
    /// The episode ended by success (terminated with a positive reward).
    success: bool,
}

/// The bot alone from `world` to the end of the episode or its give-up: advise, step with its
/// action, tell it the action.
fn alone(mut world: World) -> Alone {
    let mut expert = Expert::new(&world);
    let mut out = Alone::default();
    while !world.ended() {
        let Some(action) = expert.advise(&world, &world.observe()) else {
            out.left = Some(u64::from(world.max_steps - world.step_count));
            break;
        };
        out.labelled += 1;
        let step = world.step(action).unwrap();
        expert.told(action);
        if step.terminated || step.truncated {
            out.success = step.terminated && step.reward > 0.0;
            break;
        }
    }
    out
}

/// The bot alone on seeds `0..seeds` of `level`: every episode, after checking that
/// `label_share` counts the same labelled steps, steps and give-ups.
fn episodes(name: &str, level: &LevelConfig, seeds: u64) -> Vec<Alone> {
    let eps: Vec<Alone> = (0..seeds)
        .map(|seed| alone(level.generate(seed).unwrap()))
        .collect();
    let share = label_share(level, 0..seeds).unwrap();
    assert_eq!(share.episodes, seeds, "{name}");
    assert_eq!(
        share.labelled,
        eps.iter().map(|e| e.labelled).sum::<u64>(),
        "{name}"
    );
    assert_eq!(
        share.steps,
        eps.iter()
            .map(|e| e.labelled + e.left.unwrap_or(0))
            .sum::<u64>(),
        "{name}"
    );
    assert_eq!(
        share.gave_up,
        eps.iter().filter(|e| e.left.is_some()).count() as u64,
        "{name}"
    );
    eps
}

/// Where every key lies on the floor the bot fetches it, moves a ball off the door and picks
/// up the target: these are BabyAI's KeyCorridor, UnlockPickup and BlockedUnlockPickup
/// generators (the bot succeeds on every one of seeds 0–99 of those BabyAI ids, docs/bot.md),
/// ObstructedMaze-1Dl is UnlockPickup's layout with a ball to find, and 2Dl's two locked doors
/// have their keys in the agent's own room — the floors leave room for the seeds that differ.
#[test]
fn the_bot_solves_the_pickup_environments_whose_keys_are_on_the_floor() {
    for (id, floor) in [
        ("MiniGrid-KeyCorridorS3R1-v0", 0.9),
        ("MiniGrid-KeyCorridorS3R2-v0", 0.9),
        ("MiniGrid-KeyCorridorS3R3-v0", 0.9),
        ("MiniGrid-KeyCorridorS4R3-v0", 0.9),
        ("MiniGrid-UnlockPickup-v0", 0.9),
        ("MiniGrid-BlockedUnlockPickup-v0", 0.9),
        ("MiniGrid-ObstructedMaze-1Dl-v0", 0.9),
        ("MiniGrid-ObstructedMaze-2Dl-v0", 0.75),
    ] {
        let level = babyai(id);
        assert!(plans(&level.generate(0).unwrap()), "{id}");
        let eps = episodes(id, &level, 20);
        let solved = eps.iter().filter(|e| e.success).count();
        assert!(
            solved as f64 >= floor * eps.len() as f64,
            "{id}: the bot solved {solved} of {} episodes: {eps:?}",
            eps.len()
        );
    }
}

/// ObstructedMaze's "h" presets hide every key in a box: the bot never opens a box (its only
/// toggles are an `Open` or `Close` facing a door), so the locked doors before the ball stay
/// locked and it never succeeds; it gives up or runs to the horizon, never hangs, and what it
/// labels before is what `label_share` counts.
#[test]
fn the_bot_never_hangs_where_the_keys_are_in_boxes() {
    for id in [
        "MiniGrid-ObstructedMaze-1Dlh-v0",
        "MiniGrid-ObstructedMaze-1Dlhb-v0",
        "MiniGrid-ObstructedMaze-2Dlh-v0",
        "MiniGrid-ObstructedMaze-2Dlhb-v0",
        "MiniGrid-ObstructedMaze-2Dlhb-v1",
        "MiniGrid-ObstructedMaze-1Q-v0",
        "MiniGrid-ObstructedMaze-2Q-v1",
        "MiniGrid-ObstructedMaze-Full-v0",
        "MiniGrid-ObstructedMaze-Full-v1",
    ] {
        let level = babyai(id);
        let eps = episodes(id, &level, 10);
        assert!(eps.iter().all(|e| !e.success), "{id}: {eps:?}");
        // It plans at first (it explores before it needs a key).
        assert!(eps.iter().all(|e| e.labelled > 0), "{id}: {eps:?}");
    }
}

/// `label_share` is now above 0 on a pickup id, and still 0 — every episode given up at its
/// first step, every step unlabelled — on MiniGrid rules the bot does not plan, where the
/// expert says nothing and its plan reads `NO_EXPERT` as before.
#[test]
fn only_the_pickup_rule_gets_an_expert() {
    let share = label_share(&babyai("MiniGrid-KeyCorridorS3R1-v0"), 0..20).unwrap();
    assert!(share.labelled > 0 && share.share() > 0.0, "{share:?}");
    for id in [
        "MiniGrid-DoorKey-5x5-v0",
        "MiniGrid-Fetch-5x5-N2-v0",
        "MiniGrid-PutNear-6x6-N2-v0",
        "MiniGrid-GoToObject-6x6-N2-v0",
        "MiniGrid-Unlock-v0",
    ] {
        let level = babyai(id);
        let share = label_share(&level, 0..5).unwrap();
        assert_eq!(share.labelled, 0, "{id}");
        assert_eq!(share.share(), 0.0, "{id}");
        assert_eq!(share.gave_up, 5, "{id}");
        let world = level.generate(0).unwrap();
        assert!(!plans(&world), "{id}");
        assert_eq!(
            share.steps,
            (0..5)
                .map(|s| u64::from(level.generate(s).unwrap().max_steps))
                .sum::<u64>(),
            "{id}"
        );
        let mut expert = Expert::new(&world);
        assert_eq!(expert.advise(&world, &world.observe()), None, "{id}");
        assert_eq!(expert.plan(&world), NO_EXPERT, "{id}");
    }
}

/// The plan on a pickup id reads as on BabyAI's levels, naming the mission's object: "GoNextTo
/// blue ball → Pickup → Drop" at the start, and the same three at the bottom once it plans
/// (KeyCorridor's ball is behind a locked door, never in front of the agent at the start).
#[test]
fn the_plan_names_the_object_to_pick_up() {
    for id in [
        "MiniGrid-KeyCorridorS3R1-v0",
        "MiniGrid-UnlockPickup-v0",
        "MiniGrid-ObstructedMaze-1Dl-v0",
    ] {
        for seed in 0..5 {
            let world = babyai(id).generate(seed).unwrap();
            let target = world
                .mission
                .strip_prefix("pick up the ")
                .unwrap_or_else(|| panic!("{id}: {}", world.mission));
            let bottom = format!("GoNextTo {target} → Pickup → Drop");
            let mut expert = Expert::new(&world);
            assert_eq!(expert.plan(&world), bottom, "{id} seed {seed}");
            if id.contains("KeyCorridor") {
                let first = expert.advise(&world, &world.observe());
                assert!(first.is_some(), "{id} seed {seed}");
                let plan = expert.plan(&world);
                assert!(plan.ends_with(&bottom), "{id} seed {seed}: {plan}");
            }
        }
    }
}

/// MiniGrid rewards picking up the target itself (by identity). KeyCorridor asked for a key
/// draws the target's colour and the door's independently, so on some seeds the door's key
/// matches `pick up the <color> key` too: the bot fetches that key for the door (the target
/// is out of sight behind it), then goes on to the target — a bot heading for the closest
/// match would pick up the door's key, unrewarded, and never finish.
#[test]
fn the_bot_heads_for_the_rewarded_object_not_its_twin() {
    let level = LevelConfig::babyai(
        LevelId::parse("KeyCorridorEnv(obj_type=key, room_size=4)").unwrap(),
        false,
    );
    let (mut twins, mut solved) = (0u32, 0u32);
    for seed in 0..120 {
        let Ok(world) = level.generate(seed) else {
            continue;
        };
        let Some(Rules::Pickup { target }) = world.rules.clone() else {
            panic!("seed {seed}: {:?}", world.rules);
        };
        let t = world.grid.get(world.grid.find_id(target).unwrap()).unwrap();
        let matches = world
            .grid
            .objects()
            .filter(|(_, o)| o.kind == t.kind && o.color == t.color)
            .count();
        if matches < 2 {
            continue;
        }
        twins += 1;
        solved += u32::from(alone(world).success);
    }
    assert!(twins >= 3, "only {twins} seeds with a twin key");
    assert!(
        f64::from(solved) >= 0.9 * f64::from(twins),
        "solved {solved} of {twins} seeds with a twin key"
    );
}

/// `Class::rewards_one_pickup`, which `eval`'s report reads to show or hide the expert columns
/// of a MiniGrid id, holds exactly on the ids whose worlds the bot plans: the 21 of
/// KeyCorridor, UnlockPickup, BlockedUnlockPickup and ObstructedMaze.
#[test]
fn the_report_and_the_bot_agree_on_the_ids_with_an_expert() {
    let mut planned = 0;
    for id in LevelId::minigrid_all() {
        let class = id.minigrid().unwrap();
        let level = LevelConfig::babyai(id, false);
        let world = (0..3).find_map(|s| level.generate(s).ok()).unwrap();
        assert_eq!(class.rewards_one_pickup(), plans(&world), "{}", id.id());
        planned += u32::from(plans(&world));
    }
    assert_eq!(planned, 21);
}
