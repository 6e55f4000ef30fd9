//! The bot's subgoals and how each replans before and after an action
//! (`replan_before_action`, `replan_after_action`, `_plan_undo_action`: [`replan`]).

mod replan;

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::env::instr::Targets;
use crate::env::{ObjDesc, Pos, World};

/// The six subgoal classes of `baby_ai_bot.py`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SubgoalKind {
    /// Close the door in front.
    Close,
    /// Open the door in front (fetching its key first if it is locked).
    Open,
    /// Drop what is carried in front.
    Drop,
    /// Pick up what is in front.
    Pickup,
    /// Go next to a cell or an object and face it.
    GoNextTo,
    /// Find the closest unseen cell or closed door.
    Explore,
}

impl SubgoalKind {
    /// The Python class name (`"GoNextToSubgoal"`).
    pub fn class_name(self) -> &'static str {
        match self {
            Self::Close => "CloseSubgoal",
            Self::Open => "OpenSubgoal",
            Self::Drop => "DropSubgoal",
            Self::Pickup => "PickupSubgoal",
            Self::GoNextTo => "GoNextToSubgoal",
            Self::Explore => "ExploreSubgoal",
        }
    }

    /// The short name shown in the debugger (`"GoNextTo"`).
    pub fn name(self) -> &'static str {
        self.class_name().trim_end_matches("Subgoal")
    }
}

/// Why a subgoal was made (`reason`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Reason {
    /// GoNextTo a door to open it.
    Open,
    /// GoNextTo an empty cell next to an object, to drop beside it.
    PutNext,
    /// GoNextTo an unseen cell (exploratory: dropped when a new step starts).
    Explore,
    /// Open a locked door, then drop its key.
    Unlock,
    /// Open a locked door and keep the key.
    KeepKey,
}

impl Reason {
    /// The string minigrid uses.
    pub fn name(self) -> &'static str {
        match self {
            Self::Open => "Open",
            Self::PutNext => "PutNext",
            Self::Explore => "Explore",
            Self::Unlock => "Unlock",
            Self::KeepKey => "KeepKey",
        }
    }
}

/// A subgoal's first parameter (`datum`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Datum {
    /// A cell; `None` where minigrid's bot stored a drop position it did not find (replanning
    /// that subgoal raises in Python, so the bot gives up there).
    Pos(Option<Pos>),
    /// A description of the instruction, read live: clause `clause` in reading order, its
    /// `desc` or (PutNext) `desc_fixed`.
    Clause {
        /// Index in [`crate::env::Instr::clauses`].
        clause: usize,
        /// PutNext's fixed object.
        fixed: bool,
    },
    /// A description the bot made (a locked door's key; a MiniGrid environment's object to
    /// pick up, matching that object alone), with what it matched when made.
    Own {
        /// The description.
        desc: ObjDesc,
        /// Its matches, never refreshed.
        targets: Targets,
    },
    /// A door, by its cell (doors never move).
    Door(Pos),
}

/// One subgoal of the stack.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Subgoal {
    /// Its class.
    pub kind: SubgoalKind,
    /// Its parameter.
    pub datum: Option<Datum>,
    /// Why it was made.
    pub reason: Option<Reason>,
}

/// A description's text without its article ("red key").
fn bare(surface: &str) -> &str {
    surface.strip_prefix("a ").unwrap_or(surface)
}

impl Subgoal {
    /// A subgoal.
    pub fn new(kind: SubgoalKind, datum: Option<Datum>, reason: Option<Reason>) -> Self {
        Self {
            kind,
            datum,
            reason,
        }
    }

    pub(crate) fn go_next_to(datum: Datum, reason: Option<Reason>) -> Self {
        Self::new(SubgoalKind::GoNextTo, Some(datum), reason)
    }

    fn go_to_pos(pos: Option<Pos>) -> Self {
        Self::go_next_to(Datum::Pos(pos), None)
    }

    fn plain(kind: SubgoalKind) -> Self {
        Self::new(kind, None, None)
    }

    /// `is_exploratory`.
    pub fn is_exploratory(&self) -> bool {
        match self.kind {
            SubgoalKind::Explore => true,
            SubgoalKind::GoNextTo => self.reason == Some(Reason::Explore),
            _ => false,
        }
    }

    /// A short text, e.g. `GoNextTo (3, 5)`, `GoNextTo red key`, `Open (Unlock)`.
    pub fn describe(&self, world: &World) -> String {
        let mut s = self.kind.name().to_string();
        match &self.datum {
            Some(Datum::Pos(Some(p)) | Datum::Door(p)) => {
                let _ = write!(s, " ({}, {})", p.0, p.1);
            }
            Some(Datum::Pos(None)) => s += " (nowhere)",
            Some(Datum::Clause { clause, fixed }) => {
                if let Some(n) = world.instr.clauses().get(*clause) {
                    let d = if *fixed {
                        n.instr.fixed
                    } else {
                        Some(n.instr.desc)
                    };
                    if let Some(d) = d {
                        s += " ";
                        s += bare(&d.surface(2));
                    }
                }
            }
            Some(Datum::Own { desc, .. }) => {
                s += " ";
                s += bare(&desc.surface(2));
            }
            None => {}
        }
        if let Some(r) = self.reason {
            let _ = write!(s, " ({})", r.name());
        }
        s
    }
}
