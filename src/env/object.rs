//! MiniGrid's object, colour and state tables (`minigrid/core/constants.py`) and world objects.

use std::fmt;

use serde::{Deserialize, Serialize};

/// MiniGrid's `OBJECT_TO_IDX`: the first channel of every encoded cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[repr(u8)]
pub enum ObjectKind {
    /// Not visible (only in observations).
    Unseen = 0,
    /// A visible empty cell (only in encodings; the grid stores `None`).
    Empty = 1,
    /// A wall tile; opaque.
    Wall = 2,
    /// A floor tile; can be walked on.
    Floor = 3,
    /// A door: open, closed or locked.
    Door = 4,
    /// A key; can be picked up.
    Key = 5,
    /// A ball; can be picked up.
    Ball = 6,
    /// A box; can be picked up; toggling it deletes it (BabyAI boxes are empty).
    Box = 7,
    /// A goal tile (not used by the BabyAI levels).
    Goal = 8,
    /// A lava tile (not used by the BabyAI levels).
    Lava = 9,
    /// The agent (only in fully observable encodings).
    Agent = 10,
}

impl ObjectKind {
    /// Every kind, in index order.
    pub const ALL: [Self; 11] = [
        Self::Unseen,
        Self::Empty,
        Self::Wall,
        Self::Floor,
        Self::Door,
        Self::Key,
        Self::Ball,
        Self::Box,
        Self::Goal,
        Self::Lava,
        Self::Agent,
    ];

    /// The object types a mission can name, in BabyAI's order (`OBJ_TYPES_NOT_DOOR`).
    pub const PICKABLE: [Self; 3] = [Self::Key, Self::Ball, Self::Box];

    /// The kind with MiniGrid index `idx`, if any.
    pub fn from_index(idx: u8) -> Option<Self> {
        Self::ALL.get(usize::from(idx)).copied()
    }

    /// MiniGrid's name of the kind (`"key"`, `"ball"`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Self::Unseen => "unseen",
            Self::Empty => "empty",
            Self::Wall => "wall",
            Self::Floor => "floor",
            Self::Door => "door",
            Self::Key => "key",
            Self::Ball => "ball",
            Self::Box => "box",
            Self::Goal => "goal",
            Self::Lava => "lava",
            Self::Agent => "agent",
        }
    }

    /// The kind called `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether objects of this kind can be picked up (keys, balls, boxes).
    pub fn can_pickup(self) -> bool {
        matches!(self, Self::Key | Self::Ball | Self::Box)
    }
}

impl fmt::Display for ObjectKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// MiniGrid's `COLOR_TO_IDX`: the second channel of every encoded cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[repr(u8)]
pub enum Color {
    /// Index 0.
    Red = 0,
    /// Index 1.
    Green = 1,
    /// Index 2.
    Blue = 2,
    /// Index 3.
    Purple = 3,
    /// Index 4.
    Yellow = 4,
    /// Index 5; walls are grey.
    Grey = 5,
}

impl Color {
    /// Every colour, in index order.
    pub const ALL: [Self; 6] = [
        Self::Red,
        Self::Green,
        Self::Blue,
        Self::Purple,
        Self::Yellow,
        Self::Grey,
    ];

    /// The colour with MiniGrid index `idx`, if any.
    pub fn from_index(idx: u8) -> Option<Self> {
        Self::ALL.get(usize::from(idx)).copied()
    }

    /// MiniGrid's name of the colour.
    pub fn name(self) -> &'static str {
        match self {
            Self::Red => "red",
            Self::Green => "green",
            Self::Blue => "blue",
            Self::Purple => "purple",
            Self::Yellow => "yellow",
            Self::Grey => "grey",
        }
    }

    /// The colour called `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }

    /// MiniGrid's RGB value of the colour (`COLORS`).
    pub fn rgb(self) -> [u8; 3] {
        match self {
            Self::Red => [255, 0, 0],
            Self::Green => [0, 255, 0],
            Self::Blue => [0, 0, 255],
            Self::Purple => [112, 39, 195],
            Self::Yellow => [255, 255, 0],
            Self::Grey => [100, 100, 100],
        }
    }
}

impl fmt::Display for Color {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Door states (`STATE_TO_IDX`): the third channel of an encoded door.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[repr(u8)]
pub enum DoorState {
    /// Index 0.
    Open = 0,
    /// Index 1.
    Closed = 1,
    /// Index 2.
    Locked = 2,
}

/// Identity of an object, stable for its lifetime in one episode (BabyAI compares pickup
/// targets by Python object identity; we compare ids).
pub type ObjectId = u32;

/// One object in the world grid (never `Empty`, `Unseen` or `Agent`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct WorldObj {
    /// What the object is.
    pub kind: ObjectKind,
    /// Its colour.
    pub color: Color,
    /// Door state; `Open` (encodes as 0) for every other kind.
    pub state: DoorState,
    /// Identity within the episode.
    pub id: ObjectId,
}

impl WorldObj {
    /// A new non-door object.
    pub fn new(kind: ObjectKind, color: Color, id: ObjectId) -> Self {
        Self {
            kind,
            color,
            state: DoorState::Open,
            id,
        }
    }

    /// The MiniGrid encoding `(type, colour, state)`.
    #[inline]
    pub fn encode(&self) -> [u8; 3] {
        let state = if self.kind == ObjectKind::Door {
            self.state as u8
        } else {
            0
        };
        [self.kind as u8, self.color as u8, state]
    }

    /// Whether the agent can walk onto this object's cell.
    #[inline]
    pub fn can_overlap(&self) -> bool {
        match self.kind {
            ObjectKind::Door => self.state == DoorState::Open,
            ObjectKind::Floor | ObjectKind::Goal | ObjectKind::Lava => true,
            _ => false,
        }
    }

    /// Whether the visibility sweep propagates past this cell.
    #[inline]
    pub fn see_behind(&self) -> bool {
        match self.kind {
            ObjectKind::Wall => false,
            ObjectKind::Door => self.state == DoorState::Open,
            _ => true,
        }
    }

    /// A short human name, e.g. `"red key"`.
    pub fn describe(&self) -> String {
        format!("{} {}", self.color, self.kind)
    }
}

/// The object in a cell, where the grid stores `None` for empty cells.
pub type Cell = Option<WorldObj>;

/// Encodes a grid cell as MiniGrid does: `None` → `(1, 0, 0)`.
#[inline]
pub fn encode_cell(cell: &Cell) -> [u8; 3] {
    match cell {
        None => [ObjectKind::Empty as u8, 0, 0],
        Some(o) => o.encode(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_match_minigrid_indices() {
        assert_eq!(ObjectKind::from_name("key").map(|k| k as u8), Some(5));
        assert_eq!(ObjectKind::from_index(7), Some(ObjectKind::Box));
        assert_eq!(ObjectKind::from_index(11), None);
        assert_eq!(Color::from_name("grey").map(|c| c as u8), Some(5));
        assert_eq!(Color::from_index(6), None);
        let wall = WorldObj::new(ObjectKind::Wall, Color::Grey, 0);
        assert_eq!(wall.encode(), [2, 5, 0]);
        assert_eq!(encode_cell(&None), [1, 0, 0]);
        let mut door = WorldObj::new(ObjectKind::Door, Color::Red, 1);
        door.state = DoorState::Locked;
        assert_eq!(door.encode(), [4, 0, 2]);
        assert!(!door.see_behind() && !door.can_overlap());
    }
}
