//! The 96 `BabyAI-*` ids minigrid 3.2.0 registers, with their parameters.

use super::levelgen::{self, Params};
use super::open::SelectBy;
use super::roomgrid::{Gen, Retry};
use super::{Generated, goto, open, other, pickup, putnext, unlock};
use crate::env::grid::Rooms;
use crate::env::mission::TaskKind;
use crate::env::object::{Color, ObjectKind};

mod table;

pub use table::LEVELS;

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
    /// One of MiniGrid's own environments ([`crate::env::minigrid`]), not a BabyAI level.
    MiniGrid(crate::env::minigrid::Class),
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
            // `generate` hands these to `minigrid::generate` before any attempt.
            Self::MiniGrid(_) => Err(Retry::Endless("a MiniGrid class has no gen_mission")),
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

/// The BabyAI level registered as `id` (MiniGrid's ids: [`crate::env::LevelId::parse`]).
pub fn spec(id: &str) -> Option<&'static LevelSpec> {
    LEVELS.iter().find(|l| l.id == id)
}

/// Every registered BabyAI id.
pub fn level_ids() -> impl Iterator<Item = &'static str> {
    LEVELS.iter().map(|l| l.id)
}

/// Every registered id of both families: BabyAI's 96, then MiniGrid's 76.
pub fn all_ids() -> impl Iterator<Item = &'static str> {
    LEVELS
        .iter()
        .chain(crate::env::minigrid::registry::LEVELS)
        .map(|l| l.id)
}

/// The registered ids of both families closest to `id` (by edit distance, case-insensitive), at most three.
/// Only the first 80 characters of `id` count (longer than any id: the answer is the same,
/// and a hostile 100,000-character id costs no more than a short one).
pub fn closest_ids(id: &str) -> Vec<&'static str> {
    let want: String = id.chars().take(80).collect::<String>().to_ascii_lowercase();
    let mut scored: Vec<(usize, &'static str)> = all_ids()
        .map(|l| (edit_distance(&want, &l.to_ascii_lowercase()), l))
        .collect();
    scored.sort_unstable();
    scored.into_iter().take(3).map(|(_, l)| l).collect()
}

/// Levenshtein distance (the "did you mean" of ids, and of the Python binding's keys).
pub fn edit_distance(a: &str, b: &str) -> usize {
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
            Family::MiniGrid(c) => minigrid_mechanics(&c),
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

/// What a MiniGrid environment contains, for `env list`.
fn minigrid_mechanics(c: &crate::env::minigrid::Class) -> Mechanics {
    use crate::env::minigrid::Class as C;
    let m = |doors, locks, instructions| Mechanics {
        doors,
        locks,
        instructions,
    };
    match c {
        C::Empty { .. } | C::FourRooms { .. } => m("-", "-", "goal"),
        C::DoorKey { .. } => m("locked", "locked door, key", "goal"),
        C::LavaGap { .. } | C::Crossing { lava: true, .. } | C::DistShift { .. } => {
            m("-", "-", "goal, lava")
        }
        C::Crossing { lava: false, .. } => m("-", "-", "goal, wall openings"),
        C::DynamicObstacles { .. } => m("-", "-", "goal, moving obstacles (3 actions)"),
        C::Fetch { .. } => m("-", "-", "pickup (any pickup ends)"),
        C::GoToObject { .. } => m("-", "-", "goto (done beside it)"),
        C::GoToDoor { .. } => m("closed", "-", "goto door (done beside it)"),
        C::PutNear { .. } => m("-", "-", "put near (any drop ends)"),
        C::RedBlueDoors { .. } => m("closed", "-", "open, then"),
        C::LockedRoom { .. } => m("closed", "locked room, key", "goal"),
        C::Memory { .. } => m("-", "-", "go to the matching object"),
        C::MultiRoom { .. } => m("closed", "-", "goal"),
        C::Playground => m("closed", "-", "none (no reward)"),
        C::KeyCorridor { .. } => m("closed, corridor", "locked room, key", "pickup"),
        C::Unlock => m("locked", "locked door, key", "open"),
        C::UnlockPickup => m("locked", "locked door, key", "pickup"),
        C::BlockedUnlockPickup => m("locked", "locked door, key, blocking ball", "pickup"),
        C::ObstructedMaze1 { .. } | C::ObstructedMazeFull { .. } => m(
            "closed and locked",
            "locked doors, keys in boxes, blocking balls",
            "pickup",
        ),
    }
}
