//! Property tests of the world's invariants.

use groundscope::env::level::all_reachable;
use groundscope::env::object::encode_cell;
use groundscope::env::{
    AGENT_IN_VIEW, Action, LevelConfig, ObjectKind, TaskSet, VIEW_SIZE, world_from_view,
};
use proptest::prelude::*;

fn level() -> impl Strategy<Value = LevelConfig> {
    (
        5usize..12,
        1usize..6,
        0usize..3,
        any::<bool>(),
        any::<bool>(),
    )
        .prop_filter_map(
            "config must fit",
            |(room_size, n_objects, t, done_required, color_optional)| {
                let cfg = LevelConfig {
                    room_size,
                    n_objects,
                    tasks: [TaskSet::GoTo, TaskSet::Pickup, TaskSet::Both][t],
                    done_required,
                    color_optional,
                    babyai: None,
                };
                cfg.validate().is_ok().then_some(cfg)
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn generation_is_deterministic_and_reachable(cfg in level(), seed in any::<u64>()) {
        let a = cfg.generate(seed).unwrap();
        prop_assert_eq!(&a, &cfg.generate(seed).unwrap());
        prop_assert!(all_reachable(&a.grid, a.agent_pos));
        let n = a.grid.objects().filter(|(_, o)| o.kind != ObjectKind::Wall).count();
        prop_assert_eq!(n, cfg.n_objects);
        prop_assert!(!a.targets().is_empty());
        prop_assert_eq!(a.max_steps as usize, cfg.room_size * cfg.room_size);
    }

    #[test]
    fn random_play_keeps_the_agent_on_free_cells(cfg in level(), seed in any::<u64>(), actions in prop::collection::vec(0usize..7, 1..200)) {
        let mut w = cfg.generate(seed).unwrap();
        for a in actions {
            if w.ended() {
                prop_assert!(w.step(Action::Left).is_err(), "stepping an ended episode is an error");
                break;
            }
            let out = w.step(Action::from_index(a).unwrap()).unwrap();
            prop_assert!(w.grid.get(w.agent_pos).is_none(), "agent on an object or wall at {:?}", w.agent_pos);
            prop_assert!(out.reward >= 0.0 && out.reward <= 1.0);
            prop_assert_eq!(out.reward > 0.0, out.terminated && out.reward > 0.0);
            let obs = w.observe();
            // Every cell the agent sees shows what the world holds there (outside the grid:
            // a wall), after whatever the step changed; the cell ahead is always seen.
            for vx in 0..VIEW_SIZE {
                for vy in 0..VIEW_SIZE {
                    if (vx, vy) == AGENT_IN_VIEW || !obs.visible((vx, vy)) {
                        continue;
                    }
                    let pos = world_from_view(w.agent_pos, w.agent_dir, (vx, vy));
                    let world_cell = encode_cell(&w.grid.get_or_wall(pos));
                    prop_assert_eq!(obs.at((vx, vy)), world_cell, "view cell {:?}", (vx, vy));
                }
            }
            let ahead = (AGENT_IN_VIEW.0, AGENT_IN_VIEW.1 - 1);
            prop_assert!(obs.visible(ahead), "the cell ahead is hidden");
            // The agent's own cell is always visible: the carried object or empty.
            let own = obs.at(AGENT_IN_VIEW);
            let expected = w.carrying.map_or([1, 0, 0], |c| c.encode());
            prop_assert_eq!(own, expected);
            prop_assert!(w.step_count <= w.max_steps);
        }
    }
}

/// A level's identity has one home: every registered id and the paper's ids round-trip through
/// `LevelConfig::from_id` and `id()`, in the id's registered mode, and a bad id names itself.
#[test]
fn level_ids_round_trip_through_from_id() {
    use groundscope::env::LevelId;
    let mut n = 0;
    for l in LevelId::all() {
        let c = LevelConfig::from_id(l.id()).unwrap();
        assert_eq!(c, LevelConfig::babyai(l, false));
        assert_eq!(c.id(), l.id());
        n += 1;
    }
    assert_eq!(n, 172, "BabyAI's 96 and MiniGrid's 76");
    for (s, k) in [(8, 4), (16, 10), (5, 1), (12, 7)] {
        let id = format!("groundscope-PaperLocalS{s}N{k}-v0");
        let c = LevelConfig::from_id(&id).unwrap();
        assert_eq!(
            c,
            LevelConfig {
                room_size: s,
                n_objects: k,
                ..LevelConfig::default()
            }
        );
        assert_eq!(c.id(), id);
    }
    for bad in [
        "groundscope-PaperLocalS08N4-v0",
        "groundscope-PaperLocalS8N4",
        "groundscope-PaperLocalS3N40-v0",
        "BabyAI-GoToLocl-v0",
    ] {
        let e = LevelConfig::from_id(bad).unwrap_err().to_string();
        assert!(e.contains(bad), "{e}");
    }
}
