//! The 76 `MiniGrid-*` ids minigrid 3.2.0 registers and builds, their classes with keyword
//! arguments, and the one spelling of a class with its arguments:
//! `MultiRoomEnv(minNumRooms=7, maxNumRooms=7, maxRoomSize=8)` — minigrid's class name and
//! keyword arguments as Python takes them (see [`parse_class`]).

use crate::env::babyai::{Family, LevelSpec};
use crate::env::grid::{Pos, Rooms};
use crate::env::object::ObjectKind;

/// A MiniGrid environment class with its arguments (minigrid's names in the docs).
#[derive(Clone, Copy, Debug, PartialEq)]
#[expect(
    missing_docs,
    reason = "the fields are minigrid's keyword arguments, named alike"
)]
pub enum Class {
    /// `EmptyEnv(size, agent_start_pos, agent_start_dir)`; `None`: `place_agent`.
    Empty {
        size: i32,
        agent_start: Option<(Pos, u8)>,
    },
    /// `DoorKeyEnv(size)`.
    DoorKey { size: i32 },
    /// `FourRoomsEnv(agent_pos, goal_pos)`.
    FourRooms {
        agent_pos: Option<Pos>,
        goal_pos: Option<Pos>,
    },
    /// `LavaGapEnv(size, obstacle_type)`.
    LavaGap { size: i32, lava: bool },
    /// `DistShiftEnv(width, height, agent_start_pos, agent_start_dir, strip2_row)`.
    DistShift {
        width: i32,
        height: i32,
        agent_start: Option<(Pos, u8)>,
        strip2_row: i32,
    },
    /// `CrossingEnv(size, num_crossings, obstacle_type)`.
    Crossing {
        size: i32,
        num_crossings: usize,
        lava: bool,
    },
    /// `DynamicObstaclesEnv(size, agent_start_pos, agent_start_dir, n_obstacles)`.
    DynamicObstacles {
        size: i32,
        agent_start: Option<(Pos, u8)>,
        n_obstacles: usize,
    },
    /// `FetchEnv(size, numObjs)`.
    Fetch { size: i32, num_objs: usize },
    /// `GoToDoorEnv(size)`.
    GoToDoor { size: i32 },
    /// `GoToObjectEnv(size, numObjs)`.
    GoToObject { size: i32, num_objs: usize },
    /// `PutNearEnv(size, numObjs)`.
    PutNear { size: i32, num_objs: usize },
    /// `RedBlueDoorEnv(size)`.
    RedBlueDoors { size: i32 },
    /// `LockedRoomEnv(size)`.
    LockedRoom { size: i32 },
    /// `MemoryEnv(size, random_length)`.
    Memory { size: i32, random_length: bool },
    /// `MultiRoomEnv(minNumRooms, maxNumRooms, maxRoomSize, width, height)`.
    MultiRoom {
        min_rooms: i32,
        max_rooms: i32,
        max_room_size: i32,
        width: i32,
        height: i32,
    },
    /// `PlaygroundEnv()`.
    Playground,
    /// `KeyCorridorEnv(num_rows, obj_type, room_size)`.
    KeyCorridor {
        num_rows: i32,
        obj: ObjectKind,
        room_size: i32,
    },
    /// `UnlockEnv()`.
    Unlock,
    /// `UnlockPickupEnv()`.
    UnlockPickup,
    /// `BlockedUnlockPickupEnv()`.
    BlockedUnlockPickup,
    /// `ObstructedMaze_1Dlhb(key_in_box, blocked)`.
    ObstructedMaze1 { key_in_box: bool, blocked: bool },
    /// `ObstructedMaze_Full(agent_room, key_in_box, blocked, num_quarters,
    /// num_rooms_visited)`; `v1`: `ObstructedMaze_Full_V1` (both locked doors of a quarter,
    /// then both keys).
    ObstructedMazeFull {
        v1: bool,
        agent_room: (i32, i32),
        key_in_box: bool,
        blocked: bool,
        num_quarters: usize,
        num_rooms_visited: i32,
    },
}

const fn rooms(room_size: i32, num_rows: i32, num_cols: i32) -> Rooms {
    Rooms {
        room_size,
        num_cols,
        num_rows,
    }
}

const fn sq(s: i32) -> u32 {
    (s * s) as u32
}

impl Class {
    /// The Python class name, as the spelling writes it.
    pub const fn class_name(&self) -> &'static str {
        match self {
            Self::Empty { .. } => "EmptyEnv",
            Self::DoorKey { .. } => "DoorKeyEnv",
            Self::FourRooms { .. } => "FourRoomsEnv",
            Self::LavaGap { .. } => "LavaGapEnv",
            Self::DistShift { .. } => "DistShiftEnv",
            Self::Crossing { .. } => "CrossingEnv",
            Self::DynamicObstacles { .. } => "DynamicObstaclesEnv",
            Self::Fetch { .. } => "FetchEnv",
            Self::GoToDoor { .. } => "GoToDoorEnv",
            Self::GoToObject { .. } => "GoToObjectEnv",
            Self::PutNear { .. } => "PutNearEnv",
            Self::RedBlueDoors { .. } => "RedBlueDoorEnv",
            Self::LockedRoom { .. } => "LockedRoomEnv",
            Self::Memory { .. } => "MemoryEnv",
            Self::MultiRoom { .. } => "MultiRoomEnv",
            Self::Playground => "PlaygroundEnv",
            Self::KeyCorridor { .. } => "KeyCorridorEnv",
            Self::Unlock => "UnlockEnv",
            Self::UnlockPickup => "UnlockPickupEnv",
            Self::BlockedUnlockPickup => "BlockedUnlockPickupEnv",
            Self::ObstructedMaze1 { .. } => "ObstructedMaze_1Dlhb",
            Self::ObstructedMazeFull { v1: false, .. } => "ObstructedMaze_Full",
            Self::ObstructedMazeFull { v1: true, .. } => "ObstructedMaze_Full_V1",
        }
    }

    /// The family `env list` names (the id's stem).
    pub const fn family(&self) -> &'static str {
        match self {
            Self::Empty { .. } => "Empty",
            Self::DoorKey { .. } => "DoorKey",
            Self::FourRooms { .. } => "FourRooms",
            Self::LavaGap { .. } => "LavaGap",
            Self::DistShift { .. } => "DistShift",
            Self::Crossing { lava: true, .. } => "LavaCrossing",
            Self::Crossing { lava: false, .. } => "SimpleCrossing",
            Self::DynamicObstacles { .. } => "Dynamic-Obstacles",
            Self::Fetch { .. } => "Fetch",
            Self::GoToDoor { .. } => "GoToDoor",
            Self::GoToObject { .. } => "GoToObject",
            Self::PutNear { .. } => "PutNear",
            Self::RedBlueDoors { .. } => "RedBlueDoors",
            Self::LockedRoom { .. } => "LockedRoom",
            Self::Memory { .. } => "Memory",
            Self::MultiRoom { .. } => "MultiRoom",
            Self::Playground => "Playground",
            Self::KeyCorridor { .. } => "KeyCorridor",
            Self::Unlock => "Unlock",
            Self::UnlockPickup => "UnlockPickup",
            Self::BlockedUnlockPickup => "BlockedUnlockPickup",
            Self::ObstructedMaze1 { .. } | Self::ObstructedMazeFull { .. } => "ObstructedMaze",
        }
    }

    /// Grid width and height.
    pub const fn grid_size(&self) -> (i32, i32) {
        match *self {
            Self::Empty { size, .. }
            | Self::DoorKey { size }
            | Self::LavaGap { size, .. }
            | Self::Crossing { size, .. }
            | Self::DynamicObstacles { size, .. }
            | Self::Fetch { size, .. }
            | Self::GoToDoor { size }
            | Self::GoToObject { size, .. }
            | Self::PutNear { size, .. }
            | Self::LockedRoom { size }
            | Self::Memory { size, .. } => (size, size),
            Self::FourRooms { .. } | Self::Playground => (19, 19),
            Self::DistShift { width, height, .. } | Self::MultiRoom { width, height, .. } => {
                (width, height)
            }
            Self::RedBlueDoors { size } => (2 * size, size),
            Self::KeyCorridor { .. }
            | Self::Unlock
            | Self::UnlockPickup
            | Self::BlockedUnlockPickup
            | Self::ObstructedMaze1 { .. }
            | Self::ObstructedMazeFull { .. } => {
                let r = self.rooms();
                (
                    (r.room_size - 1) * r.num_cols + 1,
                    (r.room_size - 1) * r.num_rows + 1,
                )
            }
        }
    }

    /// The RoomGrid geometry (one room filling the grid for the other classes).
    pub const fn rooms(&self) -> Rooms {
        match *self {
            Self::KeyCorridor {
                num_rows,
                room_size,
                ..
            } => rooms(room_size, num_rows, 3),
            Self::Unlock
            | Self::UnlockPickup
            | Self::BlockedUnlockPickup
            | Self::ObstructedMaze1 { .. } => rooms(6, 1, 2),
            Self::ObstructedMazeFull { .. } => rooms(6, 3, 3),
            _ => {
                let (w, h) = self.grid_size();
                rooms(if w > h { w } else { h }, 1, 1)
            }
        }
    }

    /// The horizon when `max_steps` is not given.
    pub const fn default_max_steps(&self) -> u32 {
        match *self {
            Self::Empty { size, .. }
            | Self::LavaGap { size, .. }
            | Self::Crossing { size, .. }
            | Self::DynamicObstacles { size, .. }
            | Self::GoToDoor { size } => 4 * sq(size),
            Self::DoorKey { size } => 10 * sq(size),
            Self::FourRooms { .. } | Self::Playground => 100,
            Self::DistShift { width, height, .. } => 4 * (width * height) as u32,
            Self::Fetch { size, .. }
            | Self::GoToObject { size, .. }
            | Self::Memory { size, .. } => 5 * sq(size),
            Self::PutNear { size, .. } => 5 * size as u32,
            Self::RedBlueDoors { size } => 20 * sq(size),
            Self::LockedRoom { size } => 10 * size as u32,
            Self::MultiRoom { max_rooms, .. } => 20 * max_rooms as u32,
            Self::KeyCorridor { room_size, .. } => 30 * sq(room_size),
            // ObstructedMaze_1Dlhb: 4 · num_rooms_visited (2) · 36, UnlockEnv's 8 · 36.
            Self::Unlock | Self::UnlockPickup | Self::ObstructedMaze1 { .. } => 8 * 36,
            Self::BlockedUnlockPickup => 16 * 36,
            Self::ObstructedMazeFull {
                num_rooms_visited, ..
            } => 4 * num_rooms_visited as u32 * 36,
        }
    }

    /// minigrid's `see_through_walls` for the class (no visibility sweep when set).
    pub const fn see_through_walls(&self) -> bool {
        matches!(
            self,
            Self::Empty { .. }
                | Self::DistShift { .. }
                | Self::DynamicObstacles { .. }
                | Self::Fetch { .. }
                | Self::GoToDoor { .. }
                | Self::GoToObject { .. }
                | Self::PutNear { .. }
        )
    }

    /// The size of the action space (Dynamic-Obstacles: left, right, forward).
    pub const fn num_actions(&self) -> usize {
        match self {
            Self::DynamicObstacles { .. } => super::rules::DYNAMIC_ACTIONS,
            _ => crate::env::world::Action::COUNT,
        }
    }

    /// Every word the class's missions can use, in a fixed order.
    pub fn mission_words(&self) -> Vec<&'static str> {
        const COLORS: [&str; 6] = ["blue", "green", "grey", "purple", "red", "yellow"];
        let fixed = |s: &'static str| s.split(' ').collect::<Vec<_>>();
        let with = |mut w: Vec<&'static str>, extra: &[&'static str]| {
            w.extend_from_slice(extra);
            w
        };
        match self {
            Self::Empty { .. } | Self::DistShift { .. } | Self::DynamicObstacles { .. } => {
                fixed("get to the green goal square")
            }
            Self::DoorKey { .. } => fixed("use the key to open door and then get to goal"),
            Self::FourRooms { .. } => fixed("reach the goal"),
            Self::LavaGap { lava: true, .. } | Self::Crossing { lava: true, .. } => {
                fixed("avoid the lava and get to green goal square")
            }
            Self::LavaGap { lava: false, .. } | Self::Crossing { lava: false, .. } => {
                fixed("find the opening and get to green goal square")
            }
            Self::Fetch { .. } => with(fixed("get go fetch you must a"), &COLORS)
                .into_iter()
                .chain(["key", "ball"])
                .collect(),
            Self::GoToDoor { .. } => with(fixed("go to the door"), &COLORS),
            Self::GoToObject { .. } => with(fixed("go to the key ball box"), &COLORS),
            Self::PutNear { .. } => with(fixed("put the near key ball box"), &COLORS),
            Self::RedBlueDoors { .. } => fixed("open the red door then blue"),
            Self::LockedRoom { .. } => with(
                fixed("get the key from room, unlock door and go to goal"),
                &COLORS,
            ),
            Self::Memory { .. } => fixed("go to the matching object at end of hallway"),
            Self::MultiRoom { .. } => fixed("traverse the rooms to get goal"),
            Self::Playground => Vec::new(),
            Self::KeyCorridor { obj, .. } => with(fixed("pick up the"), &COLORS)
                .into_iter()
                .chain([obj.name()])
                .collect(),
            Self::Unlock => fixed("open the door"),
            Self::UnlockPickup | Self::BlockedUnlockPickup => {
                with(fixed("pick up the box"), &COLORS)
            }
            Self::ObstructedMaze1 { .. } | Self::ObstructedMazeFull { .. } => {
                fixed("pick up the blue ball")
            }
        }
    }
}

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

pub use super::spelling::parse_class;
