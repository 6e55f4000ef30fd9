//! The failure classes, their names and their order (the module above says how each is
//! decided).

use serde::{Deserialize, Serialize};

/// Why a failed episode failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FailureClass {
    /// No target object was ever in view.
    TargetNeverVisible,
    /// A target was in view but `M` was on it at fewer than half of those steps.
    Grounding,
    /// `done`/`pickup` ended the episode at a non-target object.
    WrongObject,
    /// Truncated while only turning left/right for the last [`TURN_WINDOW`] actions.
    TurningInPlace,
    /// None of the above.
    Other,
    /// The targets lay behind closed doors of rooms never entered, one locked and its key
    /// never carried.
    LockedDoorNoKey,
    /// The targets lay behind doors never opened (or an Open clause's door never opened).
    DoorNeverOpened,
    /// The targets lay in rooms never entered, though a door to them had been open.
    TargetRoomNeverEntered,
    /// An object of a later clause was picked up or opened first.
    WrongOrder,
    /// PutNext's object was put down beside the wrong objects.
    WrongNeighbour,
    /// Truncated while standing in one cell over the last [`TURN_WINDOW`] steps, walking
    /// into something it cannot enter (a behaviour only, never a class).
    BlockedForward,
    /// Truncated while its last [`TURN_WINDOW`] actions were all `pickup`, `drop` or `toggle`
    /// that could change nothing (nothing to pick up, nowhere to drop, nothing to open; a
    /// behaviour only).
    RepeatedNoOp,
    /// Truncated while its last [`CYCLE_WINDOW`] steps moved through at most
    /// [`CYCLE_STATES`] poses, not only turning (a loop such as right, forward, right,
    /// forward; a behaviour only).
    Cycling,
}

impl FailureClass {
    /// Every class, in report order (the order they are decided in).
    pub const ALL: [Self; 10] = [
        Self::LockedDoorNoKey,
        Self::DoorNeverOpened,
        Self::TargetRoomNeverEntered,
        Self::TargetNeverVisible,
        Self::Grounding,
        Self::WrongOrder,
        Self::WrongNeighbour,
        Self::WrongObject,
        Self::TurningInPlace,
        Self::Other,
    ];

    /// The behaviours ([`Diagnosis::behaviour`]), in the order they are decided.
    pub const BEHAVIOURS: [Self; 7] = [
        Self::WrongOrder,
        Self::WrongNeighbour,
        Self::WrongObject,
        Self::TurningInPlace,
        Self::BlockedForward,
        Self::RepeatedNoOp,
        Self::Cycling,
    ];

    /// What each class and behaviour means, in one line (`report.md` lists them).
    pub fn definition(self) -> &'static str {
        match self {
            Self::LockedDoorNoKey => {
                "the targets lay in rooms never entered behind closed doors, one locked and its key never carried"
            }
            Self::DoorNeverOpened => {
                "the targets lay behind doors never opened, or an Open clause's door never opened"
            }
            Self::TargetRoomNeverEntered => {
                "the targets lay in rooms never entered, though a door to them had been open"
            }
            Self::TargetNeverVisible => "no target object was ever in the agent's view",
            Self::Grounding => {
                "a target was in view but M pointed at it (or the cell before it) at fewer than half of those steps"
            }
            Self::WrongOrder => "an object of a later clause was picked up or opened first",
            Self::WrongNeighbour => {
                "PutNext's object was put down beside objects the clause did not name"
            }
            Self::WrongObject => {
                "`done` or `pickup` ended the episode at, or carrying, an object outside every clause"
            }
            Self::TurningInPlace => "at the step limit, the last 8 actions were all turns",
            Self::Other => {
                "none of the above (wandering to the step limit, `done` before nothing, ...)"
            }
            Self::BlockedForward => {
                "at the step limit, the agent stood in one cell over its last 8 steps, walking into something it cannot enter"
            }
            Self::RepeatedNoOp => {
                "at the step limit, the last 8 actions were pickup, drop or toggle that could change nothing"
            }
            Self::Cycling => {
                "at the step limit, the last 32 steps went round at most 8 poses (cell and direction), not only turning"
            }
        }
    }

    /// The classes of BabyAI's mechanics, reported only for cells whose levels have doors,
    /// several rooms, sequences or PutNext.
    pub const MECHANICS: [Self; 5] = [
        Self::LockedDoorNoKey,
        Self::DoorNeverOpened,
        Self::TargetRoomNeverEntered,
        Self::WrongOrder,
        Self::WrongNeighbour,
    ];

    /// The name used in `report.json`, `report.md` and `failures.json`.
    pub fn name(self) -> &'static str {
        match self {
            Self::TargetNeverVisible => "target_never_visible",
            Self::Grounding => "grounding",
            Self::WrongObject => "wrong_object",
            Self::TurningInPlace => "turning_in_place",
            Self::Other => "other",
            Self::LockedDoorNoKey => "locked_door_no_key",
            Self::DoorNeverOpened => "door_never_opened",
            Self::TargetRoomNeverEntered => "target_room_never_entered",
            Self::WrongOrder => "wrong_order",
            Self::WrongNeighbour => "wrong_neighbour",
            Self::BlockedForward => "blocked_forward",
            Self::RepeatedNoOp => "repeated_no_op",
            Self::Cycling => "cycling",
        }
    }

    /// Whether the class can be decided for a model with (`with_m`) or without `M`.
    pub fn decidable(self, with_m: bool) -> bool {
        with_m || self != Self::Grounding
    }
}

impl std::fmt::Display for FailureClass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
