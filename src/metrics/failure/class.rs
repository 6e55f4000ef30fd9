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
    // MiniGrid's own classes ([`super::minigrid`]), after BabyAI's so that the order of
    // BabyAI's (and of every report's counts of them) stays as it was.
    /// MiniGrid: the episode ended with a `forward` into lava (LavaCrossing, LavaGap,
    /// DistShift).
    SteppedIntoLava,
    /// MiniGrid: Dynamic-Obstacles ended by a collision, a `forward` into a ball or a wall.
    HitObstacle,
    /// MiniGrid: a pickup of an object other than the named one ended the episode (Fetch,
    /// PutNear).
    PickedWrongObject,
    /// MiniGrid: RedBlueDoors' blue door was opened while the red one was not open.
    DoorsOutOfOrder,
    /// MiniGrid: PutNear's drop ended the episode without the object next to the target.
    DroppedFarFromTarget,
    /// MiniGrid: Memory's agent walked to the end object that does not match.
    WrongEndObject,
    /// MiniGrid: the key the level needs lay in a box never opened (ObstructedMaze).
    BoxNeverOpened,
    /// MiniGrid: the key of the locked door the level needs was never picked up.
    KeyNeverPickedUp,
    /// MiniGrid: the key was carried but the locked door never opened.
    LockedDoorNeverOpened,
    /// MiniGrid: the locked doors were passed (or there were none) but the room of the goal
    /// or of the object to pick up was never entered (MultiRoom, KeyCorridor, ObstructedMaze).
    RoomsNeverEntered,
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

    /// MiniGrid's own classes, in the order they are decided (before every class of
    /// [`Self::ALL`], on MiniGrid's environments only): how the episode ended, then how far
    /// it got along its level's chain of box, key, locked door and rooms.
    pub const MINIGRID: [Self; 10] = [
        Self::SteppedIntoLava,
        Self::HitObstacle,
        Self::PickedWrongObject,
        Self::DoorsOutOfOrder,
        Self::DroppedFarFromTarget,
        Self::WrongEndObject,
        Self::BoxNeverOpened,
        Self::KeyNeverPickedUp,
        Self::LockedDoorNeverOpened,
        Self::RoomsNeverEntered,
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
            Self::SteppedIntoLava => {
                "MiniGrid: the episode ended on a lava cell, a `forward` into lava (LavaCrossing, LavaGap, DistShift)"
            }
            Self::HitObstacle => {
                "MiniGrid: Dynamic-Obstacles ended by a collision, a `forward` into a moving ball (or a wall) for −1"
            }
            Self::PickedWrongObject => {
                "MiniGrid: a `pickup` of an object that is not the named one ended the episode (Fetch, PutNear)"
            }
            Self::DoorsOutOfOrder => {
                "MiniGrid: RedBlueDoors' blue door was opened while the red one was not open"
            }
            Self::DroppedFarFromTarget => {
                "MiniGrid: PutNear's `drop` ended the episode without the object next to the target (8-neighbourhood)"
            }
            Self::WrongEndObject => {
                "MiniGrid: Memory's agent walked to the end object that does not match the one in the start room"
            }
            Self::BoxNeverOpened => {
                "MiniGrid: the locked door the level needs was never opened and its key lay in a box never opened (ObstructedMaze)"
            }
            Self::KeyNeverPickedUp => {
                "MiniGrid: the locked door the level needs was never opened and its key was never picked up (DoorKey, Unlock, UnlockPickup, KeyCorridor, LockedRoom, ObstructedMaze, ...)"
            }
            Self::LockedDoorNeverOpened => {
                "MiniGrid: the key was carried but the locked door the level needs was never opened"
            }
            Self::RoomsNeverEntered => {
                "MiniGrid: the locked doors were opened (or there were none) but the room of the goal or of the object to pick up was never entered (MultiRoom, KeyCorridor, ObstructedMaze, ...)"
            }
        }
    }

    /// How `report.md`'s columns name the class (and the debugger a MiniGrid one,
    /// [`Self::shown`]): BabyAI's as their name with spaces (`door never opened`, as
    /// `report.md` always wrote them), MiniGrid's in its own terms (`stepped into lava`).
    pub fn label(self) -> &'static str {
        match self {
            Self::TargetNeverVisible => "target never visible",
            Self::Grounding => "grounding",
            Self::WrongObject => "wrong object",
            Self::TurningInPlace => "turning in place",
            Self::Other => "other",
            Self::LockedDoorNoKey => "locked door no key",
            Self::DoorNeverOpened => "door never opened",
            Self::TargetRoomNeverEntered => "target room never entered",
            Self::WrongOrder => "wrong order",
            Self::WrongNeighbour => "wrong neighbour",
            Self::BlockedForward => "blocked forward",
            Self::RepeatedNoOp => "repeated no op",
            Self::Cycling => "cycling",
            Self::SteppedIntoLava => "stepped into lava",
            Self::HitObstacle => "hit an obstacle",
            Self::PickedWrongObject => "picked up the wrong object",
            Self::DoorsOutOfOrder => "opened the doors out of order",
            Self::DroppedFarFromTarget => "dropped too far from the target",
            Self::WrongEndObject => "went to the wrong end object",
            Self::BoxNeverOpened => "never opened the box",
            Self::KeyNeverPickedUp => "never picked up the key",
            Self::LockedDoorNeverOpened => "never opened the locked door",
            Self::RoomsNeverEntered => "rooms never entered",
        }
    }

    /// Whether the class is one of MiniGrid's own ([`Self::MINIGRID`]).
    pub fn is_minigrid(self) -> bool {
        Self::MINIGRID.contains(&self)
    }

    /// How the debugger's behaviour line ("failed: …") names the class: MiniGrid's by
    /// [`Self::label`], BabyAI's by [`Self::name`] as it always has.
    pub fn shown(self) -> &'static str {
        if self.is_minigrid() {
            self.label()
        } else {
            self.name()
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

    /// The name used in `report.json`, `report.md`, `failures.json` and `episodes.csv` (its
    /// serde name).
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
            Self::SteppedIntoLava => "stepped_into_lava",
            Self::HitObstacle => "hit_obstacle",
            Self::PickedWrongObject => "picked_wrong_object",
            Self::DoorsOutOfOrder => "doors_out_of_order",
            Self::DroppedFarFromTarget => "dropped_far_from_target",
            Self::WrongEndObject => "wrong_end_object",
            Self::BoxNeverOpened => "box_never_opened",
            Self::KeyNeverPickedUp => "key_never_picked_up",
            Self::LockedDoorNeverOpened => "locked_door_never_opened",
            Self::RoomsNeverEntered => "rooms_never_entered",
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
