//! The table of registered ids: each one's rooms, horizon and family with its arguments, as
//! minigrid 3.2.0's `register` calls give them.

use super::{Family, LevelSpec};
use crate::env::babyai::levelgen::{ALL_ACTIONS, ALL_INSTRS, InstrKind, Params};
use crate::env::babyai::open::SelectBy;
use crate::env::grid::Rooms;
use crate::env::mission::TaskKind;
use crate::env::object::Color;

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
