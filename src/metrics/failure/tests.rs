//! Unit tests of the failure classes: hand-made steps for each class, the counts, and the
//! counterfactual re-run on the bundled baseline.

use super::*;
use crate::env::grid::Grid;
use crate::env::level::LevelConfig;
use crate::env::mission::{Instruction, ObjDesc, TaskKind};
use crate::env::object::{Color, ObjectKind, WorldObj};
use crate::env::view::VIEW_SIZE;
use crate::episode::ActionMode;
use crate::metrics::sweep::evaluate_cell;
use crate::policy::{Net, bundled};

const TARGET: u32 = 100;
const BALL: u32 = 101;

/// A 7×7 room: the agent at (3, 5) facing `dir`, the target blue key at (3, 2) (view cell
/// (3, 3) when facing up), a red ball at `ball`, the agent carrying `carrying`.
fn room(dir: u8, ball: (i32, i32), carrying: Option<WorldObj>) -> World {
    let mut grid = Grid::new(7, 7);
    let mut id = 0;
    grid.wall_ring(&mut id);
    grid.set(
        (3, 2),
        Some(WorldObj::new(ObjectKind::Key, Color::Blue, TARGET)),
    );
    grid.set(
        ball,
        Some(WorldObj::new(ObjectKind::Ball, Color::Red, BALL)),
    );
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
    World::new(grid, (3, 5), dir, carrying, instr, 49, true, 200).unwrap()
}

const fn one_hot((x, y): ViewCell) -> ViewMap {
    let mut m = [[0.0; 7]; 7];
    m[y][x] = 1.0;
    m
}

/// How the hand-made episode ends.
#[derive(Clone, Copy)]
enum End {
    Success,
    Failure,
    Truncated,
}

/// Hand-made steps, all in `world` with its own observation, `maps[i]` (cycled) as `M`
/// (none for a baseline), the last step ending as `end`.
fn episode(world: &World, maps: &[Option<ViewMap>], actions: &[Action], end: End) -> Evidence {
    let obs = world.observe();
    let mut e = Evidence::default();
    for (i, &action) in actions.iter().enumerate() {
        let last = i + 1 == actions.len();
        let m = &maps[i % maps.len()];
        e.push(&StepFacts {
            world,
            obs: &obs,
            combined: m.as_ref(),
            action,
            reward: if last && matches!(end, End::Success) {
                0.9
            } else {
                0.0
            },
            terminated: last && matches!(end, End::Success | End::Failure),
            truncated: last && matches!(end, End::Truncated),
        });
    }
    e
}

fn class(e: &Evidence) -> FailureClass {
    e.diagnose().unwrap().class
}

/// `M` on the target's view cell, and far from it.
const ON: Option<ViewMap> = Some(one_hot((3, 3)));
const OFF: Option<ViewMap> = Some(one_hot((0, 0)));

/// `M` is on a target by where its largest cell is, not by its value: a spread map whose
/// peak (0.3, under τ = 0.5) is on the target counts, as does a peak one cell in front of
/// it; a peak beside it, behind it, or a tie won by a cell earlier in row order does not.
#[test]
fn m_is_on_the_target_by_its_largest_cell() {
    let spread = |peak: ViewCell, v: f32| {
        let mut m = [[(1.0 - v) / 48.0; VIEW_SIZE]; VIEW_SIZE];
        m[peak.1][peak.0] = v;
        m
    };
    let t = [(3, 3)];
    assert!(m_points_at(&spread((3, 3), 0.3), &t));
    assert!(m_points_at(&spread((3, 2), 0.3), &t), "one cell forward");
    assert!(!m_points_at(&spread((3, 4), 0.3), &t), "behind");
    assert!(!m_points_at(&spread((2, 3), 0.3), &t), "beside");
    assert!(
        !m_points_at(&spread((3, 3), 0.0), &t),
        "flat but for the target: points at (0, 0)"
    );
    assert!(
        m_points_at(&spread((5, 1), 0.3), &[(3, 3), (5, 1)]),
        "any target"
    );
    let mut tie = spread((3, 3), 0.3);
    tie[0][6] = 0.3;
    assert!(
        !m_points_at(&tie, &t),
        "the first largest cell in row order"
    );
}

#[test]
fn visibility_uses_the_observation() {
    let w = room(3, (5, 4), None);
    let mut obs = w.observe();
    assert_eq!(pending_targets(&w, &obs), vec![(3, 3)]);
    // The same cell marked unseen (as occlusion does) is not visible.
    obs.image[3][3] = [0, 0, 0];
    assert!(pending_targets(&w, &obs).is_empty());
    // Facing the wall below, the key is behind the agent.
    let w = room(1, (5, 4), None);
    assert!(pending_targets(&w, &w.observe()).is_empty());
}

#[test]
fn a_target_never_in_view_is_its_own_class() {
    let w = room(1, (5, 4), None);
    let e = episode(&w, &[ON], &[Action::Left; 10], End::Truncated);
    let d = e.diagnose().unwrap();
    assert_eq!(d.class, FailureClass::TargetNeverVisible);
    assert_eq!(d.target_visible_steps, 0);
    // No visible step evaluated M.
    assert_eq!(d.m_on_target_steps, None);
}

#[test]
fn m_off_the_target_at_most_visible_steps_is_grounding() {
    let w = room(3, (5, 4), None);
    let e = episode(&w, &[OFF, OFF, ON], &[Action::Left; 9], End::Truncated);
    let d = e.diagnose().unwrap();
    assert_eq!(d.class, FailureClass::Grounding);
    assert_eq!((d.target_visible_steps, d.m_on_target_steps), (9, Some(3)));
    // A tie counts as on the target: the control rules decide.
    let e = episode(&w, &[OFF, ON], &[Action::Left; 10], End::Truncated);
    assert_eq!(class(&e), FailureClass::TurningInPlace);
}

#[test]
fn done_or_pickup_at_a_non_target_is_a_wrong_object() {
    // The ball stands in front, the key visible behind it.
    let w = room(3, (3, 4), None);
    let mut actions = vec![Action::Forward; 3];
    actions.push(Action::Done);
    assert_eq!(
        class(&episode(&w, &[ON], &actions, End::Failure)),
        FailureClass::WrongObject
    );
    *actions.last_mut().unwrap() = Action::Pickup;
    assert_eq!(
        class(&episode(&w, &[ON], &actions, End::Failure)),
        FailureClass::WrongObject
    );
    // `done` while carrying a non-target, nothing in front.
    let carried = WorldObj::new(ObjectKind::Box, Color::Green, 102);
    let w = room(3, (5, 4), Some(carried));
    *actions.last_mut().unwrap() = Action::Done;
    assert_eq!(
        class(&episode(&w, &[ON], &actions, End::Failure)),
        FailureClass::WrongObject
    );
    // `done` in front of nothing is not a wrong object.
    let w = room(3, (5, 4), None);
    assert_eq!(
        class(&episode(&w, &[ON], &actions, End::Failure)),
        FailureClass::Other
    );
}

#[test]
fn only_turns_to_the_step_limit_is_turning_in_place() {
    let w = room(3, (5, 4), None);
    let mut actions = vec![Action::Forward; 5];
    actions.extend([Action::Left, Action::Right].repeat(TURN_WINDOW / 2));
    assert_eq!(
        class(&episode(&w, &[ON], &actions, End::Truncated)),
        FailureClass::TurningInPlace
    );
    // One forward inside the window: wandering, not turning in place.
    let n = actions.len();
    actions[n - TURN_WINDOW] = Action::Forward;
    assert_eq!(
        class(&episode(&w, &[ON], &actions, End::Truncated)),
        FailureClass::Other
    );
    // Fewer steps than the window never qualify.
    let short = [Action::Left; TURN_WINDOW - 1];
    assert_eq!(
        class(&episode(&w, &[ON], &short, End::Truncated)),
        FailureClass::Other
    );
}

#[test]
fn baselines_are_classed_without_m() {
    let w = room(3, (3, 4), None);
    let e = episode(&w, &[None], &[Action::Left, Action::Done], End::Failure);
    let d = e.diagnose().unwrap();
    assert_eq!(
        (d.class, d.m_on_target_steps),
        (FailureClass::WrongObject, None)
    );
    let e = episode(&w, &[None], &[Action::Right; TURN_WINDOW], End::Truncated);
    assert_eq!(class(&e), FailureClass::TurningInPlace);
    let w = room(1, (5, 4), None);
    let e = episode(&w, &[None], &[Action::Forward; 3], End::Truncated);
    assert_eq!(class(&e), FailureClass::TargetNeverVisible);
}

#[test]
fn successes_have_no_class_and_empty_evidence_does_not_panic() {
    let w = room(3, (5, 4), None);
    assert_eq!(
        episode(&w, &[OFF], &[Action::Done], End::Success).diagnose(),
        None
    );
    assert!(Evidence::default().diagnose().is_some());
}

#[test]
fn counts_hold_every_decidable_class_and_sum_to_the_failures() {
    let w = room(3, (3, 4), None);
    let diags: Vec<Diagnosis> = [
        episode(&w, &[OFF], &[Action::Left; 3], End::Truncated),
        episode(&w, &[ON], &[Action::Done], End::Failure),
        episode(&w, &[ON], &[Action::Left; TURN_WINDOW], End::Truncated),
        episode(&w, &[ON], &[Action::Done], End::Success),
    ]
    .iter()
    .filter_map(Evidence::diagnose)
    .collect();
    let counts = class_counts(&diags, true, false);
    assert_eq!(
        counts.len(),
        FailureClass::ALL.len() - FailureClass::MECHANICS.len()
    );
    assert_eq!(counts.values().sum::<u64>(), 3);
    assert_eq!(counts[&FailureClass::Grounding], 1);
    assert_eq!(counts[&FailureClass::Other], 0);
    let json = serde_json::to_string(&counts).unwrap();
    assert!(json.contains("\"target_never_visible\":0"), "{json}");
    let baseline = class_counts(&[], false, false);
    assert!(!baseline.contains_key(&FailureClass::Grounding));
    assert_eq!(
        baseline.len(),
        FailureClass::ALL.len() - FailureClass::MECHANICS.len() - 1
    );
}

#[test]
fn removing_distractors_keeps_the_targets_and_the_mission() {
    let w = LevelConfig::default().generate(7).unwrap();
    let (edited, removed) = without_distractors(&w).unwrap();
    let pickable = |w: &World| {
        w.grid
            .objects()
            .filter(|(_, o)| o.kind.can_pickup())
            .count()
    };
    assert_eq!(removed as usize + w.targets().len(), pickable(&w));
    assert_eq!(pickable(&edited), w.targets().len());
    assert_eq!(edited.targets(), w.targets());
    assert_eq!(
        (edited.mission.as_str(), edited.agent_pos),
        (w.mission.as_str(), w.agent_pos)
    );
    assert_eq!(edited.step_count, 0);
}

/// The sweep's own classes: one per failed episode, the same as a replayed trace gives,
/// and a deterministic counterfactual on each.
#[test]
fn sweep_failures_are_classed_and_rerun_without_distractors() {
    let ckpt = bundled::load("bundled:baseline").unwrap();
    let net = Net::new(ckpt.meta.model, ckpt.params.detached()).unwrap();
    let mut level = ckpt.meta.level;
    // A big room: the bundled baseline fails about a fifth of S16N10 (docs/results.md#big-rooms).
    level.room_size = 16;
    level.n_objects = 10;
    let eps = evaluate_cell(&net, &level, 0..1, 24, 0.5, ActionMode::Greedy, &mut |_| {}).unwrap();
    let failed: Vec<_> = eps.iter().filter(|e| !e.success).collect();
    assert!(!failed.is_empty(), "the baseline fails some of these");
    assert!(eps.iter().all(|e| e.success == e.failure.is_none()));
    let counts = class_counts(eps.iter().filter_map(|e| e.failure.as_ref()), false, false);
    assert_eq!(counts.values().sum::<u64>(), failed.len() as u64);
    for e in failed.iter().take(2) {
        let spec = EpisodeSpec {
            level,
            seed: e.level_seed,
            mission: None,
            mode: ActionMode::Greedy,
        };
        let trace = run_from(&net, "b", &spec, initial_world(&spec).unwrap()).unwrap();
        assert_eq!(Evidence::from_trace(&trace).diagnose(), e.failure);
        let a = counterfactual(&net, "b", &spec).unwrap();
        assert_eq!(
            a,
            counterfactual(&net, "b", &spec).unwrap(),
            "deterministic"
        );
        let (world, removed) = without_distractors(&initial_world(&spec).unwrap()).unwrap();
        assert_eq!(a.distractors_removed, removed);
        let rerun = run_from(&net, "b", &spec, world).unwrap();
        assert_eq!(
            (a.success, a.length as usize),
            (rerun.success(), rerun.steps.len())
        );
    }
}
