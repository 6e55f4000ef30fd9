//! Unit tests of the exploration statistics: hand-made episodes stepped through the real
//! world (an agent that only turns, one that walks a line, one that turns to its target),
//! the entropy edge cases, the cell aggregation, and the sweep against a replayed trace.

use super::*;
use crate::env::grid::Grid;
use crate::env::mission::{Instruction, ObjDesc, TaskKind};
use crate::env::object::{Color, ObjectKind, WorldObj};
use crate::env::view::Observation;
use crate::env::world::World;
use crate::episode::{ActionMode, EpisodeSpec, initial_world, run_from};
use crate::metrics::sweep::{EvalOptions, evaluate_cell_explored};
use crate::policy::{Net, bundled};

/// An empty `size`×`size` room (walls on the ring), the agent at `pos` facing `dir`, the
/// target blue key at `key`.
fn room(size: usize, pos: Pos, dir: u8, key: Pos) -> World {
    let mut grid = Grid::new(size, size);
    let mut id = 0;
    grid.wall_ring(&mut id);
    grid.set(key, Some(WorldObj::new(ObjectKind::Key, Color::Blue, 100)));
    let instr = Instruction {
        task: TaskKind::GoTo,
        desc: ObjDesc {
            kind: Some(ObjectKind::Key),
            color: Some(Color::Blue),
            loc: None,
        },
        fixed: None,
        strict: false,
    };
    World::new(grid, pos, dir, None, instr, 200, true, 200).unwrap()
}

/// Steps `world` through `actions` (its own observation each step, `maps` as `M` and the
/// words' weights, cycled; none for a baseline) and returns the episode's statistics.
fn walk(
    mut world: World,
    actions: &[Action],
    maps: &[(ViewMap, Vec<WordAttention>)],
) -> EpisodeExploration {
    let mut t = Tracker::default();
    for (i, &action) in actions.iter().enumerate() {
        let obs = world.observe();
        let before = world.clone();
        let out = world.step(action).unwrap();
        let m = (!maps.is_empty()).then(|| &maps[i % maps.len()]);
        t.push(
            &StepFacts {
                world: &before,
                obs: &obs,
                combined: m.map(|m| &m.0),
                action,
                reward: out.reward,
                terminated: out.terminated,
                truncated: out.truncated,
            },
            m.map(|m| m.1.as_slice()),
        );
    }
    t.finish(world.agent_pos)
}

#[test]
fn an_agent_that_only_turns_stays_on_one_cell_and_loops_after_four_turns() {
    let actions = [Action::Left; 10];
    let e = walk(room(8, (3, 3), 0, (6, 6)), &actions, &[]);
    assert_eq!(e.steps, 10);
    assert_eq!(e.floor_cells, 36);
    assert_eq!(e.visited, 1);
    assert_eq!(e.visited_frac, 1.0 / 36.0);
    assert_eq!(e.turn_frac, 1.0);
    assert_eq!(e.longest_turn_run, 10);
    // Steps 0–3 face four new directions; steps 4–9 repeat a pose.
    assert_eq!(e.revisit_frac, 0.6);
    assert!(e.maps.is_none(), "no M, no map statistics");
    // Four directions from (3, 3) in an empty 8×8 room see the whole floor.
    assert_eq!(e.seen_frac, 1.0);
    assert_eq!(
        e.first_visible_step,
        Some(0),
        "the key at (6, 6) is in view facing right"
    );
    assert!(!e.truncated, "10 of 200 steps");
}

#[test]
fn an_agent_walking_a_line_visits_steps_plus_one_cells() {
    // Up column 1 of a 10×10 room from (1, 8): 5 steps forward, never a pose twice.
    let actions = [Action::Forward; 5];
    let e = walk(room(10, (1, 8), 3, (8, 8)), &actions, &[]);
    assert_eq!(e.visited, 6);
    assert_eq!(e.visited_frac, 6.0 / 64.0);
    assert_eq!(
        (e.turn_frac, e.longest_turn_run, e.revisit_frac),
        (0.0, 0, 0.0)
    );
    // Facing up from x = 1 the view spans x −2..4 (floor x 1..4) and reaches 6 rows ahead:
    // from y = 8 the rows 2..8, then up to row 1 once the agent has walked: 4·8 cells.
    assert_eq!(e.seen_frac, 32.0 / 64.0);
    assert_eq!(
        e.first_visible_step, None,
        "the key at (8, 8) stays outside the view"
    );
}

#[test]
fn a_single_step_sees_exactly_the_visible_view_cells() {
    let world = room(10, (1, 8), 3, (8, 1));
    let mut t = Tracker::default();
    let facts = |obs| StepFacts {
        world: &world,
        obs,
        combined: None,
        action: Action::Done,
        reward: 0.0,
        terminated: true,
        truncated: false,
    };
    let obs = world.observe();
    t.push(&facts(&obs), None);
    // x 1..4 × y 2..8 of the 8×8 floor.
    assert_eq!(t.clone().finish(world.agent_pos).seen_frac, 28.0 / 64.0);
    // An observation that shows nothing (every cell unseen) sees nothing, not even the
    // agent's own cell: visibility is the observation's, as in the failure classes.
    let mut t = Tracker::default();
    let blank = Observation {
        image: [[[0; 3]; VIEW_SIZE]; VIEW_SIZE],
    };
    t.push(&facts(&blank), None);
    let e = t.finish(world.agent_pos);
    assert_eq!((e.seen_frac, e.visited, e.turn_frac), (0.0, 1, 0.0));
}

/// A uniform `M` (entropy 1, max 1/49) and two words of equal weight with uniform maps.
fn flat() -> (ViewMap, Vec<WordAttention>) {
    let u = 1.0 / 49.0;
    let word = |w: &str| WordAttention {
        word: w.into(),
        token: 1,
        map: [[u; 7]; 7],
        entropy: (49f32).ln(),
        weight: 0.5,
    };
    ([[u; 7]; 7], vec![word("blue"), word("key")])
}

/// `M` on one cell, carried by one word.
fn sharp() -> (ViewMap, Vec<WordAttention>) {
    let mut m = [[0.0; 7]; 7];
    m[3][3] = 1.0;
    let word = |w: &str, weight: f32, entropy: f32| WordAttention {
        word: w.into(),
        token: 1,
        map: m,
        entropy,
        weight,
    };
    (m, vec![word("blue", 1.0, 0.0), word("key", 0.0, 0.0)])
}

#[test]
fn maps_are_split_by_whether_a_target_is_visible() {
    // The key at (2, 2) is behind the agent at (3, 5) facing down and still behind it facing
    // right; two lefts turn it up, so steps 0–1 have no target visible (flat M) and steps
    // 2–3 have (sharp M).
    let world = room(7, (3, 5), 1, (2, 2));
    let maps = [flat(), flat(), sharp(), sharp()];
    let e = walk(world, &[Action::Left; 4], &maps);
    assert_eq!(e.first_visible_step, Some(2));
    let m = e.maps.unwrap();
    assert_eq!((m.hidden.steps, m.visible.steps), (2, 2));
    let close = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-6);
    assert!(close(m.hidden.m_entropy, 1.0), "{:?}", m.hidden.m_entropy);
    assert!(close(m.hidden.m_max, 1.0 / 49.0));
    assert!(close(m.hidden.w_entropy, 1.0));
    assert!(close(m.hidden.word_entropy, 1.0));
    assert!(close(m.visible.m_entropy, 0.0));
    assert!(close(m.visible.m_max, 1.0));
    assert!(close(m.visible.w_entropy, 0.0));
    assert!(close(m.visible.word_entropy, 0.0));
}

#[test]
fn entropy_of_bad_maps_is_left_out_never_a_panic() {
    assert_eq!(normalised_entropy([].into_iter()), None);
    assert_eq!(normalised_entropy([1.0].into_iter()), None, "one word");
    assert_eq!(normalised_entropy([0.0, 0.0].into_iter()), None);
    assert_eq!(normalised_entropy([f64::NAN, 1.0].into_iter()), None);
    assert_eq!(normalised_entropy([-1.0, 2.0].into_iter()), None);
    assert_eq!(
        normalised_entropy([2.0, 2.0].into_iter()),
        Some(1.0),
        "rescaled"
    );
    // A NaN map and weights: the step counts, its values are left out of the means.
    let mut sums = MapSums::default();
    let (_, words) = flat();
    let bad = words
        .iter()
        .map(|w| WordAttention {
            entropy: f32::NAN,
            weight: f32::NAN,
            ..w.clone()
        })
        .collect::<Vec<_>>();
    sums.add(&[[f32::NAN; 7]; 7], &bad);
    let s = sums.stats();
    assert_eq!(s.steps, 1);
    assert_eq!(
        (s.m_entropy, s.m_max, s.w_entropy, s.word_entropy),
        (None, None, None, None)
    );
    // No steps at all: zeros, no division by zero.
    let e = Tracker::default().finish((0, 0));
    assert_eq!(
        (e.steps, e.floor_cells, e.visited_frac, e.turn_frac),
        (0, 0, 0.0, 0.0)
    );
}

fn summary(seed: u64, success: bool) -> EpisodeSummary {
    EpisodeSummary {
        eval_seed: seed,
        level_seed: seed,
        mission: String::new(),
        success,
        reward: if success { 0.9 } else { 0.0 },
        length: 1,
        grounding: std::collections::BTreeMap::new(),
        failure: None,
        actions: Vec::new(),
        expert: crate::metrics::sweep::EpisodeExpert::default(),
    }
}

#[test]
fn cells_average_over_episodes_and_split_by_outcome() {
    let ep = |seen: f64, first: Option<u32>, maps: Option<MapSplit>| EpisodeExploration {
        steps: 4,
        seen_frac: seen,
        first_visible_step: first,
        maps,
        ..EpisodeExploration::default()
    };
    let split = |h: f64| MapSplit {
        hidden: MapStats {
            steps: 3,
            m_entropy: Some(h),
            ..MapStats::default()
        },
        visible: MapStats::default(),
    };
    let eps = [
        (summary(0, true), ep(1.0, Some(2), Some(split(0.2)))),
        (summary(0, false), ep(0.2, None, Some(split(0.8)))),
        (
            summary(1, false),
            EpisodeExploration {
                truncated: true,
                ..ep(0.4, None, Some(split(0.6)))
            },
        ),
    ];
    let c = cell_exploration(&eps);
    assert_eq!(
        (c.all.episodes, c.success.episodes, c.failure.episodes),
        (3, 1, 2)
    );
    assert_eq!(c.success.seen_frac.mean, Some(1.0));
    let f = &c.failure;
    assert!((f.seen_frac.mean.unwrap() - 0.3).abs() < 1e-12);
    assert!((f.seen_frac.std.unwrap() - 0.1).abs() < 1e-12);
    assert_eq!((f.never_visible, f.first_visible_step.mean), (2, None));
    assert_eq!((c.all.truncated, f.truncated), (1, 1));
    assert_eq!(c.all.first_visible_step.mean, Some(2.0));
    let maps = c.all.maps.as_ref().unwrap();
    assert_eq!((maps.hidden.steps, maps.visible.steps), (9, 0));
    assert!((maps.hidden.m_entropy.mean.unwrap() - (0.2 + 0.8 + 0.6) / 3.0).abs() < 1e-12);
    assert_eq!(
        maps.visible.m_entropy.mean, None,
        "no visible step: nothing measured"
    );
    let outcomes: Vec<&str> = c.outcomes().iter().map(|(n, _)| *n).collect();
    assert_eq!(outcomes, ["all", "success", "failure"]);
    // A baseline's episodes have no maps; an empty set is all zeros and nothing measured.
    let base = cell_exploration(&[(summary(0, true), ep(0.5, Some(0), None))]);
    assert!(base.all.maps.is_none());
    assert_eq!(
        (base.failure.episodes, base.failure.seen_frac.mean),
        (0, None)
    );
}

/// The sweep's numbers are those of the same episode replayed as a trace (the maps up to
/// the batched forward's rounding), and a second sweep gives the same numbers.
#[test]
fn sweep_exploration_matches_the_replayed_trace_and_is_deterministic() {
    let ckpt = bundled::load("bundled:attention").unwrap();
    let net = Net::new(ckpt.meta.model, ckpt.params.detached()).unwrap();
    let mut level = ckpt.meta.level;
    level.room_size = 10;
    level.n_objects = 6;
    let sweep = || {
        let opts = EvalOptions {
            alpha: 0.5,
            mode: ActionMode::Greedy,
            saliency: false,
        };
        evaluate_cell_explored(&net, &level, 0..1, 6, &opts, &mut |_| {}).unwrap()
    };
    let eps = sweep();
    assert_eq!(eps, sweep(), "deterministic");
    for (s, e) in &eps {
        let spec = EpisodeSpec {
            level,
            seed: s.level_seed,
            mission: None,
            mode: ActionMode::Greedy,
        };
        let trace = run_from(&net, "a", &spec, initial_world(&spec).unwrap()).unwrap();
        let r = Tracker::from_trace(&trace);
        assert_eq!(e.steps, s.length);
        let plain = |x: &EpisodeExploration| EpisodeExploration { maps: None, ..*x };
        assert_eq!(plain(e), plain(&r), "level seed {}", s.level_seed);
        let (a, b) = (e.maps.unwrap(), r.maps.unwrap());
        for (x, y) in [(a.hidden, b.hidden), (a.visible, b.visible)] {
            assert_eq!(x.steps, y.steps);
            for (u, v) in [
                (x.m_entropy, y.m_entropy),
                (x.m_max, y.m_max),
                (x.w_entropy, y.w_entropy),
            ] {
                assert_eq!(u.is_some(), v.is_some());
                assert!((u.unwrap_or(0.0) - v.unwrap_or(0.0)).abs() < 1e-4);
            }
        }
        for f in [e.visited_frac, e.seen_frac, e.turn_frac, e.revisit_frac] {
            assert!((0.0..=1.0).contains(&f));
        }
        assert!(e.visited as f64 <= e.seen_frac * f64::from(e.floor_cells) + 1.0);
    }
}
