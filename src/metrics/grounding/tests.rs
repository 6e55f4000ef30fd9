//! Tests of the grounding accuracies, pointing game and relevance mass.

use super::*;
use crate::env::object::{Color, ObjectKind};

fn one_hot(x: usize, y: usize) -> ViewMap {
    let mut m = [[0.0; 7]; 7];
    m[y][x] = 1.0;
    m
}

const UNIFORM: ViewMap = [[1.0 / 49.0; 7]; 7];

#[test]
fn one_hot_on_the_object_hits_everything_but_the_shift() {
    let a = accuracies(&one_hot(2, 3), &[(2, 3)], 0.5).unwrap();
    assert_eq!(a.values(), [1.0, 1.0, 0.0, 1.0]);
}

#[test]
fn around_says_which_side_of_the_object_the_map_passes() {
    // One object at (2, 3): a map one cell to its right; another at (5, 0): a map on it.
    let mut m = one_hot(3, 3);
    m[0][5] = 1.0;
    let a = accuracies(&m, &[(2, 3), (5, 0)], 0.5).unwrap();
    let mut want = [0.0; 9];
    want[5] = 0.5; // right of the first object
    want[4] = 0.5; // on the second
    assert_eq!(a.around, want);
    assert_eq!(a.acc, a.around[4]);
    assert_eq!(a.acc_bs, a.around[1]);
    assert_eq!(a.acc_ng, 1.0);
    // The offsets name the sides as the agent sees them (forward is up the view).
    assert_eq!(AROUND[1], (0, -1));
    assert_eq!((AROUND_NAMES[1], AROUND_NAMES[5]), ("forward", "right"));
    // A mean over steps keeps the offsets.
    let mut sum = a;
    sum.add(&accuracies(&one_hot(2, 2), &[(2, 3)], 0.5).unwrap());
    assert_eq!(sum.scaled(2.0).around[1], 0.5);
}

#[test]
fn pointing_and_mass_read_the_map_and_chance_is_a_uniform_maps() {
    let a = accuracies(&one_hot(2, 3), &[(2, 3), (5, 1)], 0.5).unwrap();
    assert_eq!((a.pointing, a.mass), (1.0, 1.0));
    assert_eq!(a.chance.pointing, 2.0 / 49.0);
    assert!((a.chance.mass - 2.0 / 49.0).abs() < 1e-6);
    assert_eq!(a.chance.acc, 0.0);
    // Largest cell off the objects: no point, and only the mass that is on them.
    let mut m = [[0.0; 7]; 7];
    m[0][0] = 0.6;
    m[3][2] = 0.4;
    let a = accuracies(&m, &[(2, 3)], 0.5).unwrap();
    assert_eq!(a.pointing, 0.0);
    assert!((a.mass - 0.4).abs() < 1e-6);
    // A tie between an object's cell and another: half a point.
    m[0][0] = 0.4;
    m[6][6] = 0.2;
    assert_eq!(accuracies(&m, &[(2, 3)], 0.5).unwrap().pointing, 0.5);
    // The uniform map is its own chance; at α · 49 ≤ n its acc hits.
    let u = accuracies(&UNIFORM, &[(2, 3)], 0.5).unwrap();
    assert_eq!(u.pointing, u.chance.pointing);
    let many: Vec<ViewCell> = (0..7).flat_map(|y| (0..4).map(move |x| (x, y))).collect();
    assert_eq!(accuracies(&UNIFORM, &many, 0.5).unwrap().chance.acc, 1.0);
    // Means over steps keep every figure.
    let mut sum = a;
    sum.add(&u);
    let mean = sum.scaled(2.0);
    assert!((mean.chance.pointing - 1.0 / 49.0).abs() < 1e-12);
    assert_eq!(Accuracies::ALL_NAMES[4], "pointing");
}

/// The half-planes are the start pose's: at reset "left" is the view's left three columns,
/// "in front" its six rows ahead, "behind" nothing in view; once the agent has turned left,
/// what was in front of it at the start is on its right.
#[test]
fn a_location_region_is_the_start_poses_half_plane_carried_into_the_view() {
    use crate::env::Loc;
    let mut world = crate::env::level::LevelConfig::default()
        .generate(3)
        .unwrap();
    let start = (world.agent_pos, world.agent_dir);
    let cells = |w: &World, loc| location_region(w, loc, start);
    let left = cells(&world, Loc::Left);
    assert_eq!(left.len(), 21);
    assert!(left.iter().all(|&(vx, _)| vx < 3));
    let right = cells(&world, Loc::Right);
    assert!(right.len() == 21 && right.iter().all(|&(vx, _)| vx > 3));
    let front = cells(&world, Loc::Front);
    assert!(front.len() == 42 && front.iter().all(|&(_, vy)| vy < 6));
    assert!(cells(&world, Loc::Behind).is_empty());
    world.step(crate::env::world::Action::Left).unwrap();
    let front = cells(&world, Loc::Front);
    assert!(front.iter().all(|&(vx, _)| vx > 3), "{front:?}");
    assert_eq!(front.len(), 21);
    // A uniform map's mass on a region is its share of the view.
    assert!((relevance_mass(&UNIFORM, &front) - 21.0 / 49.0).abs() < 1e-6);
}

#[test]
fn a_uniform_map_misses_at_alpha_one_half() {
    let a = accuracies(&UNIFORM, &[(2, 3)], 0.5).unwrap();
    assert_eq!(a.values(), [0.0; 4]);
    // ... and hits everywhere when α is tiny.
    let a = accuracies(&UNIFORM, &[(2, 3)], 0.01).unwrap();
    assert_eq!(a.values(), [1.0; 4]);
}

#[test]
fn a_map_shifted_one_cell_forward_hits_bs_ng_and_cmb() {
    let a = accuracies(&one_hot(2, 2), &[(2, 3)], 0.5).unwrap();
    assert_eq!(a.values(), [0.0, 1.0, 1.0, 1.0]);
}

#[test]
fn an_object_on_row_zero_has_no_forward_shift() {
    let mut m = one_hot(4, 0);
    m[6][0] = 0.9; // far away, irrelevant
    let a = accuracies(&m, &[(4, 0)], 0.5).unwrap();
    assert_eq!(a.values(), [1.0, 1.0, 0.0, 1.0]);
    let miss = accuracies(&one_hot(5, 1), &[(4, 0)], 0.5).unwrap();
    assert_eq!(miss.values(), [0.0, 1.0, 0.0, 0.0]);
}

#[test]
fn several_objects_share_the_threshold() {
    // Two related objects: τ = 0.25; half the mass on each.
    let mut m = [[0.0; 7]; 7];
    m[1][1] = 0.3;
    m[4][5] = 0.2;
    let a = accuracies(&m, &[(1, 1), (5, 4)], 0.5).unwrap();
    assert_eq!(a.acc, 0.5, "only the first reaches τ = 0.25");
    assert_eq!(a.acc_ng, 0.5);
}

#[test]
fn steps_without_related_objects_are_not_evaluated() {
    assert_eq!(accuracies(&UNIFORM, &[], 0.5), None);
    // A world whose view shows nothing (every cell unseen): no word and no M evaluated.
    let world = crate::env::level::LevelConfig::default()
        .generate(0)
        .unwrap();
    let obs = Observation {
        image: [[[0, 0, 0]; 7]; 7],
    };
    let n = crate::env::vocab::split_words(&world.mission).len();
    let words: Vec<(&str, &ViewMap)> = (0..n).map(|_| ("w", &UNIFORM)).collect();
    assert!(
        ground_step(&world, &obs, &words, &UNIFORM, 0.5)
            .evaluated
            .is_empty()
    );
}

#[test]
fn the_carried_object_and_walls_are_not_related() {
    let mut obs = Observation {
        image: [[[1, 0, 0]; 7]; 7],
    };
    obs.image[3][6] = [5, 0, 0]; // carried red key in the agent's cell
    obs.image[0][0] = [2, 5, 0]; // grey wall
    obs.image[1][2] = [5, 0, 0]; // red key at vx 1, vy 2
    obs.image[4][1] = [4, 0, 1]; // closed red door at vx 4, vy 1
    assert_eq!(
        related_objects(&obs, |k, _| k == ObjectKind::Key),
        vec![(1, 2)]
    );
    assert!(related_objects(&obs, |_, c| c == Color::Grey).is_empty());
    assert_eq!(related_objects(&obs, |_, c| c == Color::Red), vec![(1, 2)]);
    assert_eq!(
        visible_objects(&obs, |_, c| c == Color::Red),
        vec![(4, 1), (1, 2)],
        "doors count where a description names one"
    );
}

/// Every scored word's objects carry the word's meaning, on levels of every instruction
/// kind; `M`'s are objects of the clauses the verifier waits on.
#[test]
fn each_word_is_scored_on_what_it_names_on_every_instruction_kind() {
    use crate::env::level::{LevelConfig, LevelId};
    use crate::env::vocab::split_words;
    let mut kinds_seen = std::collections::BTreeSet::new();
    for id in [
        "BabyAI-GoToLocal-v0",
        "BabyAI-PickupLoc-v0",
        "BabyAI-GoToObjDoor-v0",
        "BabyAI-PutNextLocal-v0",
        "BabyAI-SynthSeq-v0",
        "BabyAI-OpenDoorLoc-v0",
        // MiniGrid's own words: goal, lava, opening, and colours of goals and rooms.
        "MiniGrid-LavaGapS5-v0",
        "MiniGrid-SimpleCrossingS9N1-v0",
        "MiniGrid-DoorKey-5x5-v0",
        "MiniGrid-PutNear-6x6-N2-v0",
        "MiniGrid-LockedRoom-v0",
    ] {
        // BabyAI's in the paper's done-action mode as before; MiniGrid's have none.
        let level = LevelConfig::babyai(LevelId::parse(id).unwrap(), id.starts_with("BabyAI-"));
        for seed in 0..40 {
            let mut world = level.generate(seed).unwrap();
            for step in 0..6 {
                let obs = world.observe();
                let words = split_words(&world.mission);
                let maps: Vec<(&str, &ViewMap)> =
                    words.iter().map(|w| (w.as_str(), &UNIFORM)).collect();
                let g = ground_step(&world, &obs, &maps, &UNIFORM, 0.5);
                for e in &g.evaluated {
                    kinds_seen.insert(e.kind);
                    for h in &e.hits {
                        let [t, c, _] = obs.at(h.cell);
                        let (kind, color) = (
                            ObjectKind::from_index(t).unwrap(),
                            Color::from_index(c).unwrap(),
                        );
                        let word = e.word.map(|i| words[i].as_str());
                        match e.kind {
                            WordKind::Object if word != Some("object") => {
                                assert_eq!(Some(kind.name()), word, "{id} {seed}");
                            }
                            WordKind::Color => {
                                assert_eq!(Some(color.name()), word, "{id} {seed}");
                            }
                            WordKind::Door => assert_eq!(kind, ObjectKind::Door),
                            WordKind::Goal => assert_eq!(kind, ObjectKind::Goal),
                            WordKind::Lava => assert_eq!(kind, ObjectKind::Lava),
                            WordKind::Opening => assert_eq!(kind, ObjectKind::Empty),
                            _ => {}
                        }
                    }
                }
                for e in &g.evaluated {
                    assert_eq!(
                        e.accuracies.region.is_some(),
                        e.kind == WordKind::Location,
                        "{id} {seed}: only location words have a region"
                    );
                }
                // `M`'s targets are exactly the pending clauses' objects in view.
                let m = g.evaluated.iter().find(|e| e.kind == WordKind::Combined);
                let cells: Vec<ViewCell> = m
                    .map(|e| e.hits.iter().map(|h| h.cell).collect())
                    .unwrap_or_default();
                assert_eq!(cells, pending_targets(&world, &obs), "{id} {seed}");
                if world
                    .step(crate::env::world::Action::Left)
                    .unwrap()
                    .terminated
                {
                    break;
                }
                let _ = step;
            }
        }
    }
    for k in WordKind::ALL {
        assert!(kinds_seen.contains(&k), "{k:?} never evaluated");
    }
}
