//! The 76 ids minigrid 3.2.0 registers and builds, with the classes and keyword arguments of
//! its `register` calls, and the six WFC ids it registers but cannot build.

use super::registry::Class;
use crate::env::babyai::{Family, LevelSpec};
use crate::env::object::ObjectKind;

const fn lvl(id: &'static str, class: Class) -> LevelSpec {
    LevelSpec {
        id,
        rooms: class.rooms(),
        max_steps: Some(class.default_max_steps()),
        family: Family::MiniGrid(class),
    }
}

const fn empty(size: i32, random: bool) -> Class {
    Class::Empty {
        size,
        agent_start: if random { None } else { Some(((1, 1), 0)) },
    }
}

const fn dynamic(size: i32, n_obstacles: usize, random: bool) -> Class {
    Class::DynamicObstacles {
        size,
        agent_start: if random { None } else { Some(((1, 1), 0)) },
        n_obstacles,
    }
}

const fn crossing(size: i32, num_crossings: usize, lava: bool) -> Class {
    Class::Crossing {
        size,
        num_crossings,
        lava,
    }
}

const fn multi(min_rooms: i32, max_rooms: i32, max_room_size: i32) -> Class {
    Class::MultiRoom {
        min_rooms,
        max_rooms,
        max_room_size,
        width: 25,
        height: 25,
    }
}

const fn kc(room_size: i32, num_rows: i32) -> Class {
    Class::KeyCorridor {
        num_rows,
        obj: ObjectKind::Ball,
        room_size,
    }
}

const fn om1(key_in_box: bool, blocked: bool) -> Class {
    Class::ObstructedMaze1 {
        key_in_box,
        blocked,
    }
}

const fn om(
    v1: bool,
    agent_room: (i32, i32),
    key_in_box: bool,
    blocked: bool,
    num_quarters: usize,
    num_rooms_visited: i32,
) -> Class {
    Class::ObstructedMazeFull {
        v1,
        agent_room,
        key_in_box,
        blocked,
        num_quarters,
        num_rooms_visited,
    }
}

const fn dist_shift(strip2_row: i32) -> Class {
    Class::DistShift {
        width: 9,
        height: 7,
        agent_start: Some(((1, 1), 0)),
        strip2_row,
    }
}

/// The 76 ids, sorted, with the classes and arguments minigrid registers them with.
pub const LEVELS: &[LevelSpec] = &[
    lvl(
        "MiniGrid-BlockedUnlockPickup-v0",
        Class::BlockedUnlockPickup,
    ),
    lvl("MiniGrid-DistShift1-v0", dist_shift(2)),
    lvl("MiniGrid-DistShift2-v0", dist_shift(5)),
    lvl("MiniGrid-DoorKey-16x16-v0", Class::DoorKey { size: 16 }),
    lvl("MiniGrid-DoorKey-5x5-v0", Class::DoorKey { size: 5 }),
    lvl("MiniGrid-DoorKey-6x6-v0", Class::DoorKey { size: 6 }),
    lvl("MiniGrid-DoorKey-8x8-v0", Class::DoorKey { size: 8 }),
    lvl("MiniGrid-Dynamic-Obstacles-16x16-v0", dynamic(16, 8, false)),
    lvl("MiniGrid-Dynamic-Obstacles-5x5-v0", dynamic(5, 2, false)),
    lvl("MiniGrid-Dynamic-Obstacles-6x6-v0", dynamic(6, 3, false)),
    lvl("MiniGrid-Dynamic-Obstacles-8x8-v0", dynamic(8, 4, false)),
    lvl(
        "MiniGrid-Dynamic-Obstacles-Random-5x5-v0",
        dynamic(5, 2, true),
    ),
    lvl(
        "MiniGrid-Dynamic-Obstacles-Random-6x6-v0",
        dynamic(6, 3, true),
    ),
    lvl("MiniGrid-Empty-16x16-v0", empty(16, false)),
    lvl("MiniGrid-Empty-5x5-v0", empty(5, false)),
    lvl("MiniGrid-Empty-6x6-v0", empty(6, false)),
    lvl("MiniGrid-Empty-8x8-v0", empty(8, false)),
    lvl("MiniGrid-Empty-Random-5x5-v0", empty(5, true)),
    lvl("MiniGrid-Empty-Random-6x6-v0", empty(6, true)),
    lvl(
        "MiniGrid-Fetch-5x5-N2-v0",
        Class::Fetch {
            size: 5,
            num_objs: 2,
        },
    ),
    lvl(
        "MiniGrid-Fetch-6x6-N2-v0",
        Class::Fetch {
            size: 6,
            num_objs: 2,
        },
    ),
    lvl(
        "MiniGrid-Fetch-8x8-N3-v0",
        Class::Fetch {
            size: 8,
            num_objs: 3,
        },
    ),
    lvl(
        "MiniGrid-FourRooms-v0",
        Class::FourRooms {
            agent_pos: None,
            goal_pos: None,
        },
    ),
    lvl("MiniGrid-GoToDoor-5x5-v0", Class::GoToDoor { size: 5 }),
    lvl("MiniGrid-GoToDoor-6x6-v0", Class::GoToDoor { size: 6 }),
    lvl("MiniGrid-GoToDoor-8x8-v0", Class::GoToDoor { size: 8 }),
    lvl(
        "MiniGrid-GoToObject-6x6-N2-v0",
        Class::GoToObject {
            size: 6,
            num_objs: 2,
        },
    ),
    lvl(
        "MiniGrid-GoToObject-8x8-N2-v0",
        Class::GoToObject {
            size: 8,
            num_objs: 2,
        },
    ),
    lvl("MiniGrid-KeyCorridorS3R1-v0", kc(3, 1)),
    lvl("MiniGrid-KeyCorridorS3R2-v0", kc(3, 2)),
    lvl("MiniGrid-KeyCorridorS3R3-v0", kc(3, 3)),
    lvl("MiniGrid-KeyCorridorS4R3-v0", kc(4, 3)),
    lvl("MiniGrid-KeyCorridorS5R3-v0", kc(5, 3)),
    lvl("MiniGrid-KeyCorridorS6R3-v0", kc(6, 3)),
    lvl("MiniGrid-LavaCrossingS11N5-v0", crossing(11, 5, true)),
    lvl("MiniGrid-LavaCrossingS9N1-v0", crossing(9, 1, true)),
    lvl("MiniGrid-LavaCrossingS9N2-v0", crossing(9, 2, true)),
    lvl("MiniGrid-LavaCrossingS9N3-v0", crossing(9, 3, true)),
    lvl(
        "MiniGrid-LavaGapS5-v0",
        Class::LavaGap {
            size: 5,
            lava: true,
        },
    ),
    lvl(
        "MiniGrid-LavaGapS6-v0",
        Class::LavaGap {
            size: 6,
            lava: true,
        },
    ),
    lvl(
        "MiniGrid-LavaGapS7-v0",
        Class::LavaGap {
            size: 7,
            lava: true,
        },
    ),
    lvl("MiniGrid-LockedRoom-v0", Class::LockedRoom { size: 19 }),
    lvl(
        "MiniGrid-MemoryS11-v0",
        Class::Memory {
            size: 11,
            random_length: false,
        },
    ),
    lvl(
        "MiniGrid-MemoryS13-v0",
        Class::Memory {
            size: 13,
            random_length: false,
        },
    ),
    lvl(
        "MiniGrid-MemoryS13Random-v0",
        Class::Memory {
            size: 13,
            random_length: true,
        },
    ),
    lvl(
        "MiniGrid-MemoryS17Random-v0",
        Class::Memory {
            size: 17,
            random_length: true,
        },
    ),
    lvl(
        "MiniGrid-MemoryS7-v0",
        Class::Memory {
            size: 7,
            random_length: false,
        },
    ),
    lvl(
        "MiniGrid-MemoryS9-v0",
        Class::Memory {
            size: 9,
            random_length: false,
        },
    ),
    lvl("MiniGrid-MultiRoom-N2-S4-v0", multi(2, 2, 4)),
    // The -v0 id kept for compatibility builds 6 rooms (minigrid issue #471).
    lvl("MiniGrid-MultiRoom-N4-S5-v0", multi(6, 6, 5)),
    lvl("MiniGrid-MultiRoom-N4-S5-v1", multi(4, 4, 5)),
    lvl("MiniGrid-MultiRoom-N6-v0", multi(6, 6, 10)),
    lvl("MiniGrid-ObstructedMaze-1Dl-v0", om1(false, false)),
    lvl("MiniGrid-ObstructedMaze-1Dlh-v0", om1(true, false)),
    lvl("MiniGrid-ObstructedMaze-1Dlhb-v0", om1(true, true)),
    lvl(
        "MiniGrid-ObstructedMaze-1Q-v0",
        om(false, (1, 1), true, true, 1, 5),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-1Q-v1",
        om(true, (1, 1), true, true, 1, 5),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-2Dl-v0",
        om(false, (2, 1), false, false, 1, 4),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-2Dlh-v0",
        om(false, (2, 1), true, false, 1, 4),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-2Dlhb-v0",
        om(false, (2, 1), true, true, 1, 4),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-2Dlhb-v1",
        om(true, (2, 1), true, true, 1, 4),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-2Q-v0",
        om(false, (2, 1), true, true, 2, 11),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-2Q-v1",
        om(true, (2, 1), true, true, 2, 11),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-Full-v0",
        om(false, (1, 1), true, true, 4, 25),
    ),
    lvl(
        "MiniGrid-ObstructedMaze-Full-v1",
        om(true, (1, 1), true, true, 4, 25),
    ),
    lvl("MiniGrid-Playground-v0", Class::Playground),
    lvl(
        "MiniGrid-PutNear-6x6-N2-v0",
        Class::PutNear {
            size: 6,
            num_objs: 2,
        },
    ),
    lvl(
        "MiniGrid-PutNear-8x8-N3-v0",
        Class::PutNear {
            size: 8,
            num_objs: 3,
        },
    ),
    lvl(
        "MiniGrid-RedBlueDoors-6x6-v0",
        Class::RedBlueDoors { size: 6 },
    ),
    lvl(
        "MiniGrid-RedBlueDoors-8x8-v0",
        Class::RedBlueDoors { size: 8 },
    ),
    lvl("MiniGrid-SimpleCrossingS11N5-v0", crossing(11, 5, false)),
    lvl("MiniGrid-SimpleCrossingS9N1-v0", crossing(9, 1, false)),
    lvl("MiniGrid-SimpleCrossingS9N2-v0", crossing(9, 2, false)),
    lvl("MiniGrid-SimpleCrossingS9N3-v0", crossing(9, 3, false)),
    lvl("MiniGrid-Unlock-v0", Class::Unlock),
    lvl("MiniGrid-UnlockPickup-v0", Class::UnlockPickup),
];

/// The six `MiniGrid-WFC-*` ids minigrid registers but cannot build from its PyPI wheel (no
/// pattern files ship with it), so no reference exists to be exact against.
pub const WFC_IDS: [&str; 6] = [
    "MiniGrid-WFC-DungeonMazeScaled-v0",
    "MiniGrid-WFC-MazeSimple-v0",
    "MiniGrid-WFC-ObstaclesAngular-v0",
    "MiniGrid-WFC-ObstaclesBlackdots-v0",
    "MiniGrid-WFC-ObstaclesHogs3-v0",
    "MiniGrid-WFC-RoomsFabric-v0",
];
