//! The 96 `BabyAI-*` ids minigrid 3.2.0 registers, with their parameters.

use super::levelgen::{self, ALL_ACTIONS, ALL_INSTRS, InstrKind, Params};
use super::open::SelectBy;
use super::roomgrid::{Gen, Retry};
use super::{Generated, goto, open, other, pickup, putnext, unlock};
use crate::env::grid::Rooms;
use crate::env::mission::TaskKind;
use crate::env::object::{Color, ObjectKind};

/// A level family with its parameters (the Python class and its keyword arguments).
#[derive(Clone, Copy, Debug, PartialEq)]
#[expect(
    missing_docs,
    reason = "the variants and fields are minigrid's classes and arguments"
)]
pub enum Family {
    GoToRedBallGrey {
        num_dists: usize,
    },
    GoToRedBall {
        num_dists: usize,
    },
    GoToObj,
    /// `GoToLocal`; with `task` Pickup, the paper's pick-up twin.
    GoToLocal {
        num_dists: usize,
        task: TaskKind,
    },
    /// The paper's level ([`crate::env::LevelConfig`]): GoToLocal, then the task drawn
    /// from `tasks` when it holds two, then the colour dropped one time in seven when
    /// `color_optional`.
    Paper {
        num_dists: usize,
        tasks: crate::env::TaskSet,
        color_optional: bool,
    },
    GoTo {
        num_dists: usize,
        doors_open: bool,
    },
    GoToImpUnlock,
    GoToRedBlueBall {
        num_dists: usize,
    },
    GoToDoor,
    GoToObjDoor,
    Open,
    OpenRedDoor,
    OpenDoor {
        debug: bool,
        select_by: Option<SelectBy>,
    },
    OpenTwoDoors {
        first: Option<Color>,
        second: Option<Color>,
        strict: bool,
    },
    OpenDoorsOrder {
        num_doors: usize,
        debug: bool,
    },
    Pickup,
    UnblockPickup,
    PickupDist {
        debug: bool,
    },
    PickupAbove,
    PutNextLocal {
        num_objs: usize,
    },
    PutNext {
        objs_per_room: usize,
        start_carrying: bool,
    },
    MoveTwoAcross {
        objs_per_room: usize,
    },
    ActionObjDoor,
    FindObj,
    KeyCorridor,
    OneRoom,
    Unlock,
    UnlockLocal {
        distractors: bool,
    },
    KeyInBox,
    UnlockPickup {
        distractors: bool,
    },
    BlockedUnlockPickup,
    UnlockToUnlock,
    LevelGen(Params),
}

impl Family {
    /// `gen_mission` of the family.
    pub fn gen_mission(&self, g: &mut Gen) -> Result<Generated, Retry> {
        match *self {
            Self::GoToRedBallGrey { num_dists } => goto::red_ball_grey(g, num_dists),
            Self::GoToRedBall { num_dists } => goto::red_ball(g, num_dists),
            Self::GoToObj => goto::obj(g),
            Self::GoToLocal { num_dists, task } => goto::local(g, num_dists, task),
            Self::Paper {
                num_dists,
                tasks,
                color_optional,
            } => goto::paper(g, num_dists, tasks, color_optional),
            Self::GoTo {
                num_dists,
                doors_open,
            } => goto::maze(g, num_dists, doors_open),
            Self::GoToImpUnlock => goto::imp_unlock(g),
            Self::GoToRedBlueBall { num_dists } => goto::red_blue_ball(g, num_dists),
            Self::GoToDoor => goto::door(g),
            Self::GoToObjDoor => goto::obj_door(g),
            Self::Open => goto::open_any(g),
            Self::OpenRedDoor => open::red_door(g),
            Self::OpenDoor { debug, select_by } => open::door(g, debug, select_by),
            Self::OpenTwoDoors {
                first,
                second,
                strict,
            } => open::two_doors(g, first, second, strict),
            Self::OpenDoorsOrder { num_doors, debug } => open::doors_order(g, num_doors, debug),
            Self::Pickup => pickup::maze(g),
            Self::UnblockPickup => pickup::unblock(g),
            Self::PickupDist { debug } => pickup::dist(g, debug),
            Self::PickupAbove => pickup::above(g),
            Self::PutNextLocal { num_objs } => putnext::local(g, num_objs),
            Self::PutNext {
                objs_per_room,
                start_carrying,
            } => putnext::two_rooms(g, objs_per_room, start_carrying),
            Self::MoveTwoAcross { objs_per_room } => putnext::move_two_across(g, objs_per_room),
            Self::ActionObjDoor => other::action_obj_door(g),
            Self::FindObj => other::find_obj(g),
            Self::KeyCorridor => other::key_corridor(g, ObjectKind::Ball),
            Self::OneRoom => other::one_room(g),
            Self::Unlock => unlock::unlock(g),
            Self::UnlockLocal { distractors } => unlock::local(g, distractors),
            Self::KeyInBox => unlock::key_in_box(g),
            Self::UnlockPickup { distractors } => unlock::unlock_pickup(g, distractors),
            Self::BlockedUnlockPickup => unlock::blocked_unlock_pickup(g),
            Self::UnlockToUnlock => unlock::unlock_to_unlock(g),
            Self::LevelGen(p) => levelgen::gen_mission(g, &p),
        }
    }
}

/// A level: its id, rooms, horizon and family.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelSpec {
    /// The gym id, e.g. `BabyAI-GoToLocalS8N4-v0`.
    pub id: &'static str,
    /// The rooms.
    pub rooms: Rooms,
    /// A fixed horizon; `None`: `num_navs · room_size² · rooms` (RoomGridLevel's rule).
    pub max_steps: Option<u32>,
    /// The family and its parameters.
    pub family: Family,
}

const fn rooms(room_size: i32, num_rows: i32, num_cols: i32) -> Rooms {
    Rooms {
        room_size,
        num_cols,
        num_rows,
    }
}

const fn lvl(id: &'static str, rooms: Rooms, max_steps: Option<u32>, family: Family) -> LevelSpec {
    LevelSpec {
        id,
        rooms,
        max_steps,
        family,
    }
}

const fn one(s: i32) -> Rooms {
    rooms(s, 1, 1)
}

/// The default RoomGridLevel: 3 × 3 rooms of 8.
const NINE: Rooms = rooms(8, 3, 3);

const fn lg(p: Params) -> Family {
    Family::LevelGen(p)
}

const B: Params = Params::BOSS;

#[expect(
    clippy::unnecessary_wraps,
    reason = "it fills the spec's optional horizon"
)]
const fn sq(s: u32, k: u32) -> Option<u32> {
    Some(k * s * s)
}

const fn gtl(num_dists: usize) -> Family {
    Family::GoToLocal {
        num_dists,
        task: TaskKind::GoTo,
    }
}

const fn maze(num_dists: usize, doors_open: bool) -> Family {
    Family::GoTo {
        num_dists,
        doors_open,
    }
}

const fn putnext(objs_per_room: usize, start_carrying: bool) -> Family {
    Family::PutNext {
        objs_per_room,
        start_carrying,
    }
}

/// Every registered id, sorted as gym lists them.
pub const LEVELS: &[LevelSpec] = &[
    lvl(
        "BabyAI-ActionObjDoor-v0",
        rooms(7, 3, 3),
        None,
        Family::ActionObjDoor,
    ),
    lvl(
        "BabyAI-BlockedUnlockPickup-v0",
        rooms(6, 1, 2),
        sq(6, 16),
        Family::BlockedUnlockPickup,
    ),
    lvl("BabyAI-BossLevel-v0", NINE, None, lg(B)),
    lvl(
        "BabyAI-BossLevelNoUnlock-v0",
        NINE,
        None,
        lg(Params {
            locked_room_prob: 0.0,
            implicit_unlock: false,
            ..B
        }),
    ),
    lvl(
        "BabyAI-FindObjS5-v0",
        rooms(5, 3, 3),
        sq(5, 20),
        Family::FindObj,
    ),
    lvl(
        "BabyAI-FindObjS6-v0",
        rooms(6, 3, 3),
        sq(6, 20),
        Family::FindObj,
    ),
    lvl(
        "BabyAI-FindObjS7-v0",
        rooms(7, 3, 3),
        sq(7, 20),
        Family::FindObj,
    ),
    lvl("BabyAI-GoTo-v0", NINE, None, maze(18, false)),
    lvl("BabyAI-GoToDoor-v0", rooms(7, 3, 3), None, Family::GoToDoor),
    lvl("BabyAI-GoToImpUnlock-v0", NINE, None, Family::GoToImpUnlock),
    lvl("BabyAI-GoToLocal-v0", one(8), None, gtl(8)),
    lvl("BabyAI-GoToLocalS5N2-v0", one(5), None, gtl(2)),
    lvl("BabyAI-GoToLocalS6N2-v0", one(6), None, gtl(2)),
    lvl("BabyAI-GoToLocalS6N3-v0", one(6), None, gtl(3)),
    lvl("BabyAI-GoToLocalS6N4-v0", one(6), None, gtl(4)),
    lvl("BabyAI-GoToLocalS7N4-v0", one(7), None, gtl(4)),
    lvl("BabyAI-GoToLocalS7N5-v0", one(7), None, gtl(5)),
    lvl("BabyAI-GoToLocalS8N2-v0", one(8), None, gtl(2)),
    lvl("BabyAI-GoToLocalS8N3-v0", one(8), None, gtl(3)),
    lvl("BabyAI-GoToLocalS8N4-v0", one(8), None, gtl(4)),
    lvl("BabyAI-GoToLocalS8N5-v0", one(8), None, gtl(5)),
    lvl("BabyAI-GoToLocalS8N6-v0", one(8), None, gtl(6)),
    lvl("BabyAI-GoToLocalS8N7-v0", one(8), None, gtl(7)),
    lvl("BabyAI-GoToObj-v0", one(8), None, Family::GoToObj),
    lvl("BabyAI-GoToObjDoor-v0", NINE, None, Family::GoToObjDoor),
    lvl("BabyAI-GoToObjMaze-v0", NINE, None, maze(1, false)),
    lvl("BabyAI-GoToObjMazeOpen-v0", NINE, None, maze(1, true)),
    lvl(
        "BabyAI-GoToObjMazeS4-v0",
        rooms(4, 3, 3),
        None,
        maze(1, false),
    ),
    lvl(
        "BabyAI-GoToObjMazeS4R2-v0",
        rooms(4, 2, 2),
        None,
        maze(1, false),
    ),
    lvl(
        "BabyAI-GoToObjMazeS5-v0",
        rooms(5, 3, 3),
        None,
        maze(1, false),
    ),
    lvl(
        "BabyAI-GoToObjMazeS6-v0",
        rooms(6, 3, 3),
        None,
        maze(1, false),
    ),
    lvl(
        "BabyAI-GoToObjMazeS7-v0",
        rooms(7, 3, 3),
        None,
        maze(1, false),
    ),
    lvl("BabyAI-GoToObjS4-v0", one(4), None, Family::GoToObj),
    lvl("BabyAI-GoToObjS6-v1", one(6), None, Family::GoToObj),
    lvl("BabyAI-GoToOpen-v0", NINE, None, maze(18, true)),
    lvl(
        "BabyAI-GoToRedBall-v0",
        one(8),
        None,
        Family::GoToRedBall { num_dists: 7 },
    ),
    lvl(
        "BabyAI-GoToRedBallGrey-v0",
        one(8),
        None,
        Family::GoToRedBallGrey { num_dists: 7 },
    ),
    lvl(
        "BabyAI-GoToRedBallNoDists-v0",
        one(8),
        None,
        Family::GoToRedBall { num_dists: 0 },
    ),
    lvl(
        "BabyAI-GoToRedBlueBall-v0",
        one(8),
        None,
        Family::GoToRedBlueBall { num_dists: 7 },
    ),
    lvl(
        "BabyAI-GoToSeq-v0",
        NINE,
        None,
        lg(Params {
            action_kinds: &[TaskKind::GoTo],
            locked_room_prob: 0.0,
            locations: false,
            unblocking: false,
            ..B
        }),
    ),
    lvl(
        "BabyAI-GoToSeqS5R2-v0",
        rooms(5, 2, 2),
        None,
        lg(Params {
            num_dists: 4,
            action_kinds: &[TaskKind::GoTo],
            locked_room_prob: 0.0,
            locations: false,
            unblocking: false,
            ..B
        }),
    ),
    lvl(
        "BabyAI-KeyCorridor-v0",
        rooms(6, 3, 3),
        sq(6, 30),
        Family::KeyCorridor,
    ),
    lvl(
        "BabyAI-KeyCorridorS3R1-v0",
        rooms(3, 1, 3),
        sq(3, 30),
        Family::KeyCorridor,
    ),
    lvl(
        "BabyAI-KeyCorridorS3R2-v0",
        rooms(3, 2, 3),
        sq(3, 30),
        Family::KeyCorridor,
    ),
    lvl(
        "BabyAI-KeyCorridorS3R3-v0",
        rooms(3, 3, 3),
        sq(3, 30),
        Family::KeyCorridor,
    ),
    lvl(
        "BabyAI-KeyCorridorS4R3-v0",
        rooms(4, 3, 3),
        sq(4, 30),
        Family::KeyCorridor,
    ),
    lvl(
        "BabyAI-KeyCorridorS5R3-v0",
        rooms(5, 3, 3),
        sq(5, 30),
        Family::KeyCorridor,
    ),
    lvl(
        "BabyAI-KeyCorridorS6R3-v0",
        rooms(6, 3, 3),
        sq(6, 30),
        Family::KeyCorridor,
    ),
    lvl("BabyAI-KeyInBox-v0", NINE, None, Family::KeyInBox),
    lvl(
        "BabyAI-MiniBossLevel-v0",
        rooms(5, 2, 2),
        None,
        lg(Params {
            num_dists: 7,
            locked_room_prob: 0.25,
            ..B
        }),
    ),
    lvl(
        "BabyAI-MoveTwoAcrossS5N2-v0",
        rooms(5, 1, 2),
        sq(5, 16),
        Family::MoveTwoAcross { objs_per_room: 2 },
    ),
    lvl(
        "BabyAI-MoveTwoAcrossS8N9-v0",
        rooms(8, 1, 2),
        sq(8, 16),
        Family::MoveTwoAcross { objs_per_room: 9 },
    ),
    lvl("BabyAI-OneRoomS12-v0", one(12), None, Family::OneRoom),
    lvl("BabyAI-OneRoomS16-v0", one(16), None, Family::OneRoom),
    lvl("BabyAI-OneRoomS20-v0", one(20), None, Family::OneRoom),
    lvl("BabyAI-OneRoomS8-v0", one(8), None, Family::OneRoom),
    lvl("BabyAI-Open-v0", NINE, None, Family::Open),
    lvl(
        "BabyAI-OpenDoor-v0",
        NINE,
        None,
        Family::OpenDoor {
            debug: false,
            select_by: None,
        },
    ),
    lvl(
        "BabyAI-OpenDoorColor-v0",
        NINE,
        None,
        Family::OpenDoor {
            debug: false,
            select_by: Some(SelectBy::Color),
        },
    ),
    lvl(
        "BabyAI-OpenDoorDebug-v0",
        NINE,
        None,
        Family::OpenDoor {
            debug: true,
            select_by: None,
        },
    ),
    lvl(
        "BabyAI-OpenDoorLoc-v0",
        NINE,
        None,
        Family::OpenDoor {
            debug: false,
            select_by: Some(SelectBy::Loc),
        },
    ),
    lvl(
        "BabyAI-OpenDoorsOrderN2-v0",
        rooms(6, 3, 3),
        sq(6, 20),
        Family::OpenDoorsOrder {
            num_doors: 2,
            debug: false,
        },
    ),
    lvl(
        "BabyAI-OpenDoorsOrderN2Debug-v0",
        rooms(6, 3, 3),
        sq(6, 20),
        Family::OpenDoorsOrder {
            num_doors: 2,
            debug: true,
        },
    ),
    lvl(
        "BabyAI-OpenDoorsOrderN4-v0",
        rooms(6, 3, 3),
        sq(6, 20),
        Family::OpenDoorsOrder {
            num_doors: 4,
            debug: false,
        },
    ),
    lvl(
        "BabyAI-OpenDoorsOrderN4Debug-v0",
        rooms(6, 3, 3),
        sq(6, 20),
        Family::OpenDoorsOrder {
            num_doors: 4,
            debug: true,
        },
    ),
    lvl(
        "BabyAI-OpenRedBlueDoors-v0",
        rooms(6, 3, 3),
        sq(6, 20),
        Family::OpenTwoDoors {
            first: Some(Color::Red),
            second: Some(Color::Blue),
            strict: false,
        },
    ),
    lvl(
        "BabyAI-OpenRedBlueDoorsDebug-v0",
        rooms(6, 3, 3),
        sq(6, 20),
        Family::OpenTwoDoors {
            first: Some(Color::Red),
            second: Some(Color::Blue),
            strict: true,
        },
    ),
    lvl(
        "BabyAI-OpenRedDoor-v0",
        rooms(5, 1, 2),
        None,
        Family::OpenRedDoor,
    ),
    lvl(
        "BabyAI-OpenTwoDoors-v0",
        rooms(6, 3, 3),
        sq(6, 20),
        Family::OpenTwoDoors {
            first: None,
            second: None,
            strict: false,
        },
    ),
    lvl("BabyAI-Pickup-v0", NINE, None, Family::Pickup),
    lvl(
        "BabyAI-PickupAbove-v0",
        rooms(6, 3, 3),
        sq(6, 8),
        Family::PickupAbove,
    ),
    lvl(
        "BabyAI-PickupDist-v0",
        one(7),
        None,
        Family::PickupDist { debug: false },
    ),
    lvl(
        "BabyAI-PickupDistDebug-v0",
        one(7),
        None,
        Family::PickupDist { debug: true },
    ),
    lvl(
        "BabyAI-PickupLoc-v0",
        one(8),
        None,
        lg(Params {
            num_dists: 8,
            action_kinds: &[TaskKind::Pickup],
            instr_kinds: &[InstrKind::Action],
            locked_room_prob: 0.0,
            locations: true,
            unblocking: false,
            ..B
        }),
    ),
    lvl(
        "BabyAI-PutNextLocal-v0",
        one(8),
        None,
        Family::PutNextLocal { num_objs: 8 },
    ),
    lvl(
        "BabyAI-PutNextLocalS5N3-v0",
        one(5),
        None,
        Family::PutNextLocal { num_objs: 3 },
    ),
    lvl(
        "BabyAI-PutNextLocalS6N4-v0",
        one(6),
        None,
        Family::PutNextLocal { num_objs: 4 },
    ),
    lvl(
        "BabyAI-PutNextS4N1-v0",
        rooms(4, 1, 2),
        sq(4, 8),
        putnext(1, false),
    ),
    lvl(
        "BabyAI-PutNextS5N1-v0",
        rooms(5, 1, 2),
        sq(5, 8),
        putnext(1, false),
    ),
    lvl(
        "BabyAI-PutNextS5N2-v0",
        rooms(5, 1, 2),
        sq(5, 8),
        putnext(2, false),
    ),
    lvl(
        "BabyAI-PutNextS5N2Carrying-v0",
        rooms(5, 1, 2),
        sq(5, 8),
        putnext(2, true),
    ),
    lvl(
        "BabyAI-PutNextS6N3-v0",
        rooms(6, 1, 2),
        sq(6, 8),
        putnext(3, false),
    ),
    lvl(
        "BabyAI-PutNextS6N3Carrying-v0",
        rooms(6, 1, 2),
        sq(6, 8),
        putnext(3, true),
    ),
    lvl(
        "BabyAI-PutNextS7N4-v0",
        rooms(7, 1, 2),
        sq(7, 8),
        putnext(4, false),
    ),
    lvl(
        "BabyAI-PutNextS7N4Carrying-v0",
        rooms(7, 1, 2),
        sq(7, 8),
        putnext(4, true),
    ),
    lvl(
        "BabyAI-Synth-v0",
        NINE,
        None,
        lg(Params {
            instr_kinds: &[InstrKind::Action],
            locations: false,
            implicit_unlock: false,
            ..B
        }),
    ),
    lvl(
        "BabyAI-SynthLoc-v0",
        NINE,
        None,
        lg(Params {
            instr_kinds: &[InstrKind::Action],
            implicit_unlock: false,
            ..B
        }),
    ),
    lvl(
        "BabyAI-SynthS5R2-v0",
        rooms(5, 2, 3),
        None,
        lg(Params {
            instr_kinds: &[InstrKind::Action],
            locations: false,
            implicit_unlock: false,
            ..B
        }),
    ),
    lvl(
        "BabyAI-SynthSeq-v0",
        NINE,
        None,
        lg(Params {
            implicit_unlock: false,
            ..B
        }),
    ),
    lvl("BabyAI-UnblockPickup-v0", NINE, None, Family::UnblockPickup),
    lvl("BabyAI-Unlock-v0", NINE, None, Family::Unlock),
    lvl(
        "BabyAI-UnlockLocal-v0",
        NINE,
        None,
        Family::UnlockLocal { distractors: false },
    ),
    lvl(
        "BabyAI-UnlockLocalDist-v0",
        NINE,
        None,
        Family::UnlockLocal { distractors: true },
    ),
    lvl(
        "BabyAI-UnlockPickup-v0",
        rooms(6, 1, 2),
        None,
        Family::UnlockPickup { distractors: false },
    ),
    lvl(
        "BabyAI-UnlockPickupDist-v0",
        rooms(6, 1, 2),
        None,
        Family::UnlockPickup { distractors: true },
    ),
    lvl(
        "BabyAI-UnlockToUnlock-v0",
        rooms(6, 1, 3),
        sq(6, 30),
        Family::UnlockToUnlock,
    ),
];

// Unused-constant guards: every action and instruction kind is listed above.
const _: &[TaskKind] = ALL_ACTIONS;
const _: &[InstrKind] = ALL_INSTRS;

/// The level registered as `id`.
pub fn spec(id: &str) -> Option<&'static LevelSpec> {
    LEVELS.iter().find(|l| l.id == id)
}

/// Every registered id.
pub fn level_ids() -> impl Iterator<Item = &'static str> {
    LEVELS.iter().map(|l| l.id)
}

/// The registered ids closest to `id` (by edit distance, case-insensitive), at most three.
/// Only the first 80 characters of `id` count (longer than any id: the answer is the same,
/// and a hostile 100,000-character id costs no more than a short one).
pub fn closest_ids(id: &str) -> Vec<&'static str> {
    let want: String = id.chars().take(80).collect::<String>().to_ascii_lowercase();
    let mut scored: Vec<(usize, &'static str)> = level_ids()
        .map(|l| (edit_distance(&want, &l.to_ascii_lowercase()), l))
        .collect();
    scored.sort_unstable();
    scored.into_iter().take(3).map(|(_, l)| l).collect()
}

/// Levenshtein distance.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != *cb))
                .min(prev[j + 1] + 1)
                .min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ninety_six_ids_sorted_and_unique() {
        assert_eq!(LEVELS.len(), 96);
        assert!(LEVELS.windows(2).all(|w| w[0].id < w[1].id));
        assert_eq!(closest_ids("BabyAI-GoToLocal-v1")[0], "BabyAI-GoToLocal-v0");
        assert_eq!(closest_ids("babyai-bosslevel-v0")[0], "BabyAI-BossLevel-v0");
    }
}

/// What a level contains, for `env list`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mechanics {
    /// Doors between rooms (closed unless said open).
    pub doors: &'static str,
    /// Locked doors and keys.
    pub locks: &'static str,
    /// The instruction kinds its missions use.
    pub instructions: &'static str,
}

impl LevelSpec {
    /// What the level contains (doors, locks, instruction kinds).
    pub fn mechanics(&self) -> Mechanics {
        let m = |doors, locks, instructions| Mechanics {
            doors,
            locks,
            instructions,
        };
        match self.family {
            Family::GoToRedBallGrey { .. }
            | Family::GoToRedBall { .. }
            | Family::GoToObj
            | Family::GoToRedBlueBall { .. } => m("-", "-", "goto"),
            Family::GoToLocal { task, .. } => m(
                "-",
                "-",
                if task == TaskKind::GoTo {
                    "goto"
                } else {
                    "pickup"
                },
            ),
            Family::Paper { .. } => m("-", "-", "goto, pickup"),
            Family::GoTo { doors_open, .. } => {
                m(if doors_open { "open" } else { "closed" }, "-", "goto")
            }
            Family::GoToImpUnlock => m("closed", "locked room, key", "goto"),
            Family::GoToDoor => m("closed or locked", "locked, no key", "goto door"),
            Family::GoToObjDoor => m("closed or locked", "locked, no key", "goto"),
            Family::Open | Family::OpenRedDoor | Family::OpenDoor { .. } => {
                m("closed", "-", "open")
            }
            Family::OpenTwoDoors { .. } => m("closed", "-", "open, before"),
            Family::OpenDoorsOrder { .. } => m("closed", "-", "open, before, after"),
            Family::Pickup | Family::UnblockPickup | Family::FindObj | Family::PickupAbove => {
                m("closed", "-", "pickup")
            }
            Family::PickupDist { .. } | Family::OneRoom => m("-", "-", "pickup"),
            Family::PutNextLocal { .. } => m("-", "-", "putnext"),
            Family::PutNext { start_carrying, .. } => m(
                "wall removed",
                "-",
                if start_carrying {
                    "putnext (carrying)"
                } else {
                    "putnext"
                },
            ),
            Family::MoveTwoAcross { .. } => m("wall removed", "-", "putnext, before"),
            Family::ActionObjDoor => m("closed", "-", "goto, pickup, open"),
            Family::KeyCorridor => m("closed, corridor", "locked room, key", "pickup"),
            Family::Unlock => m("closed", "locked room, key", "open"),
            Family::UnlockLocal { .. } => m("closed", "locked door, key", "open"),
            Family::KeyInBox => m("closed", "locked door, key in a box", "open"),
            Family::UnlockPickup { .. } | Family::BlockedUnlockPickup => {
                m("locked", "locked door, key", "pickup")
            }
            Family::UnlockToUnlock => m("locked", "two locked doors, keys", "pickup"),
            Family::LevelGen(p) => {
                let locks = if p.locked_room_prob > 0.0 {
                    "locked room (maybe), key"
                } else {
                    "-"
                };
                let instructions = match (p.action_kinds.len(), p.instr_kinds.len()) {
                    (1, 1) if p.locations => "pickup, locations",
                    (1, _) => "goto, and, before, after",
                    (_, 1) if p.locations => "goto, pickup, open, putnext, locations",
                    (_, 1) => "goto, pickup, open, putnext",
                    _ => "goto, pickup, open, putnext, and, before, after, locations",
                };
                m("closed", locks, instructions)
            }
        }
    }
}
