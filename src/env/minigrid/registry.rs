//! The 76 `MiniGrid-*` ids minigrid 3.2.0 registers and builds, their classes with keyword
//! arguments, and the one spelling of a class with its arguments:
//! `MultiRoomEnv(minNumRooms=7, maxNumRooms=7, maxRoomSize=8)` — minigrid's class name and
//! keyword arguments as Python takes them (see [`parse_class`]).

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

    /// Whether its `step` rewards picking up one object ([`super::Rules::Pickup`]):
    /// KeyCorridor, UnlockPickup, BlockedUnlockPickup and ObstructedMaze, whose missions are
    /// BabyAI pickup instructions.
    pub const fn rewards_one_pickup(&self) -> bool {
        matches!(
            self,
            Self::KeyCorridor { .. }
                | Self::UnlockPickup
                | Self::BlockedUnlockPickup
                | Self::ObstructedMaze1 { .. }
                | Self::ObstructedMazeFull { .. }
        )
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

pub use super::ids::{LEVELS, WFC_IDS};
pub use super::spelling::parse_class;
