//! MiniGrid's seven actions.

use std::fmt;

use serde::{Deserialize, Serialize};

/// MiniGrid's seven actions (`minigrid/core/actions.py`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[repr(u8)]
pub enum Action {
    /// Turn left (counter-clockwise).
    Left = 0,
    /// Turn right (clockwise).
    Right = 1,
    /// Move one cell forward if the cell can be entered.
    Forward = 2,
    /// Pick up the object in front.
    Pickup = 3,
    /// Drop the carried object onto the empty cell in front.
    Drop = 4,
    /// Toggle the object in front (opens doors, deletes boxes).
    Toggle = 5,
    /// Declare the task done (only meaningful in done-action mode).
    Done = 6,
}

impl Action {
    /// Every action, in index order.
    pub const ALL: [Self; 7] = [
        Self::Left,
        Self::Right,
        Self::Forward,
        Self::Pickup,
        Self::Drop,
        Self::Toggle,
        Self::Done,
    ];

    /// Number of actions (the policy's logits).
    pub const COUNT: usize = 7;

    /// The action with index `idx`, if any.
    pub fn from_index(idx: usize) -> Option<Self> {
        Self::ALL.get(idx).copied()
    }

    /// MiniGrid's name of the action.
    pub fn name(self) -> &'static str {
        match self {
            Self::Left => "left",
            Self::Right => "right",
            Self::Forward => "forward",
            Self::Pickup => "pickup",
            Self::Drop => "drop",
            Self::Toggle => "toggle",
            Self::Done => "done",
        }
    }
}

impl fmt::Display for Action {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
