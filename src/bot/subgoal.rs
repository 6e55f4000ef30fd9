//! The bot's subgoals and how each replans before and after an action
//! (`replan_before_action`, `replan_after_action`, `_plan_undo_action`).

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::env::instr::Targets;
use crate::env::{Action, Cell, DoorState, ObjDesc, ObjectKind, Pos, World};

use super::search::closest_wall_or_door;
use super::{Bot, GiveUp, Pose};

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
    /// A description the bot made (a locked door's key), with what it matched when made.
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

fn broken(what: &'static str) -> GiveUp {
    GiveUp::Broken(what.to_owned())
}

fn add(a: Pos, b: Pos) -> Pos {
    (a.0 + b.0, a.1 + b.1)
}

fn sub(a: Pos, b: Pos) -> Pos {
    (a.0 - b.0, a.1 - b.1)
}

fn manhattan(a: Pos, b: Pos) -> i32 {
    (a.0 - b.0).abs() + (a.1 - b.1).abs()
}

/// A description's text without its article ("red key").
fn bare(surface: &str) -> &str {
    surface.strip_prefix("a ").unwrap_or(surface)
}

fn is_open_door(cell: Cell) -> bool {
    cell.is_some_and(|o| o.kind == ObjectKind::Door && o.state == DoorState::Open)
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

impl Bot {
    /// `_plan_undo_action`: plan to undo an action someone else took.
    fn plan_undo(
        &mut self,
        world: &World,
        pose: Pose,
        taken: Option<Action>,
    ) -> Result<(), GiveUp> {
        let carrying = world.carrying.map(|c| c.id);
        let fwd_cell = world.grid.get(pose.fwd_pos);
        match taken {
            Some(Action::Forward) if self.memory.agent_pos != pose.pos => {
                self.stack.push(Subgoal::go_to_pos(Some(pose.pos)));
            }
            Some(Action::Left) => self
                .stack
                .push(Subgoal::go_to_pos(Some(add(pose.pos, pose.right_vec)))),
            Some(Action::Right) => self
                .stack
                .push(Subgoal::go_to_pos(Some(sub(pose.pos, pose.right_vec)))),
            Some(Action::Drop) if self.memory.carrying != carrying => {
                if !fwd_cell.is_some_and(|o| {
                    matches!(o.kind, ObjectKind::Key | ObjectKind::Box | ObjectKind::Ball)
                }) {
                    return Err(broken("a dropped object is not in front"));
                }
                self.stack.push(Subgoal::plain(SubgoalKind::Pickup));
            }
            Some(Action::Pickup) if self.memory.carrying != carrying => {
                self.stack.push(Subgoal::plain(SubgoalKind::Drop));
            }
            Some(Action::Toggle) => {
                if let Some(door) = fwd_cell.filter(|o| o.kind == ObjectKind::Door) {
                    let was_open = self
                        .memory
                        .fwd_door_was_open
                        .ok_or_else(|| broken("fwd_door_was_open was never set"))?;
                    let open = door.state == DoorState::Open;
                    if was_open != open {
                        self.stack.push(Subgoal::plain(if open {
                            SubgoalKind::Close
                        } else {
                            SubgoalKind::Open
                        }));
                    }
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// `replan_after_action` of the subgoal on top.
    pub(super) fn after_action(
        &mut self,
        world: &World,
        pose: Pose,
        top: &Subgoal,
        taken: Option<Action>,
    ) -> Result<(), GiveUp> {
        use Action::{Drop, Forward, Left, Pickup, Right, Toggle};
        let moved = matches!(taken, Some(Forward | Left | Right));
        match top.kind {
            // Done by its own action; a move taken instead is undone.
            SubgoalKind::Close | SubgoalKind::Drop => {
                let own = if top.kind == SubgoalKind::Close {
                    Toggle
                } else {
                    Drop
                };
                if taken.is_none_or(|a| a == own) {
                    self.stack.pop();
                } else if moved {
                    self.plan_undo(world, pose, taken)?;
                }
            }
            SubgoalKind::Open => {
                if matches!(taken, None | Some(Toggle)) {
                    self.stack.pop();
                    if top.reason == Some(Reason::Unlock) {
                        // Chosen only now: a cell chosen earlier may be taken by then.
                        let drop_key = self.planner.find_drop_pos(world, None)?;
                        self.stack.push(Subgoal::plain(SubgoalKind::Drop));
                        self.stack.push(Subgoal::go_to_pos(drop_key));
                    }
                } else {
                    self.plan_undo(world, pose, taken)?;
                }
            }
            SubgoalKind::Pickup => {
                if matches!(taken, None | Some(Pickup)) {
                    self.stack.pop();
                } else if matches!(taken, Some(Left | Right)) {
                    self.plan_undo(world, pose, taken)?;
                }
            }
            SubgoalKind::GoNextTo => {
                if matches!(taken, Some(Pickup | Drop | Toggle)) {
                    self.plan_undo(world, pose, taken)?;
                }
            }
            SubgoalKind::Explore => {}
        }
        Ok(())
    }

    /// `replan_before_action` of the subgoal on top: an action, or `None` when the stack
    /// changed and the bot must replan.
    pub(super) fn before_action(
        &mut self,
        world: &World,
        pose: Pose,
        top: &Subgoal,
    ) -> Result<Option<Action>, GiveUp> {
        let fwd_cell = world.grid.get(pose.fwd_pos);
        match top.kind {
            SubgoalKind::Close => {
                let door = fwd_cell.ok_or_else(|| broken("Forward cell is empty"))?;
                if door.kind != ObjectKind::Door {
                    return Err(broken("Forward cell has to be a door"));
                }
                if door.state != DoorState::Open {
                    return Err(broken("Forward door must be open"));
                }
                Ok(Some(Action::Toggle))
            }
            SubgoalKind::Open => self.open_before(world, pose, top),
            SubgoalKind::Drop => {
                if world.carrying.is_none() {
                    return Err(broken("Drop: nothing is carried"));
                }
                if fwd_cell.is_some() {
                    return Err(broken("Drop: the cell in front is not empty"));
                }
                Ok(Some(Action::Drop))
            }
            SubgoalKind::Pickup => {
                if world.carrying.is_some() {
                    return Err(broken("Pickup: something is carried already"));
                }
                Ok(Some(Action::Pickup))
            }
            SubgoalKind::GoNextTo => self.go_next_to_before(world, pose, top),
            SubgoalKind::Explore => self.explore_before(world),
        }
    }

    fn open_before(
        &mut self,
        world: &World,
        pose: Pose,
        top: &Subgoal,
    ) -> Result<Option<Action>, GiveUp> {
        let door = world
            .grid
            .get(pose.fwd_pos)
            .ok_or_else(|| broken("Forward cell is empty"))?;
        if door.kind != ObjectKind::Door {
            return Err(broken("Forward cell has to be a door"));
        }
        let got_the_key = world
            .carrying
            .is_some_and(|c| c.kind == ObjectKind::Key && c.color == door.color);
        let locked = door.state == DoorState::Locked;
        if locked && !got_the_key {
            let key = Self::key_desc(world, door.color);
            self.stack.pop();
            if world.carrying.is_some() {
                // Put down what is carried, fetch the key, open, then take it back.
                let drop_pos_cur = self.planner.find_drop_pos(world, None)?;
                self.stack.push(Subgoal::plain(SubgoalKind::Pickup));
                self.stack.push(Subgoal::go_to_pos(drop_pos_cur));
                self.stack.push(Subgoal::plain(SubgoalKind::Open));
                self.stack.push(Subgoal::go_to_pos(Some(pose.fwd_pos)));
                self.stack.push(Subgoal::plain(SubgoalKind::Pickup));
                self.stack.push(Subgoal::go_next_to(key, None));
                self.stack.push(Subgoal::plain(SubgoalKind::Drop));
                self.stack.push(Subgoal::go_to_pos(drop_pos_cur));
            } else {
                self.stack.push(Subgoal::plain(SubgoalKind::Open));
                self.stack.push(Subgoal::go_to_pos(Some(pose.fwd_pos)));
                self.stack.push(Subgoal::plain(SubgoalKind::Pickup));
                self.stack.push(Subgoal::go_next_to(key, None));
            }
            return Ok(None);
        }
        if door.state == DoorState::Open {
            self.stack.push(Subgoal::plain(SubgoalKind::Close));
            return Ok(None);
        }
        if locked && top.reason.is_none() {
            self.stack.pop();
            self.stack
                .push(Subgoal::new(SubgoalKind::Open, None, Some(Reason::Unlock)));
            return Ok(None);
        }
        Ok(Some(Action::Toggle))
    }

    fn go_next_to_before(
        &mut self,
        world: &World,
        pose: Pose,
        top: &Subgoal,
    ) -> Result<Option<Action>, GiveUp> {
        let put_next = top.reason == Some(Reason::PutNext);
        let datum = top
            .datum
            .as_ref()
            .ok_or_else(|| broken("GoNextTo without a target"))?;
        // (the door to open, when the target is one)
        let mut target_door = None;
        let target_pos = match datum {
            Datum::Pos(p) => p.ok_or_else(|| broken("GoNextTo a position that was never found"))?,
            Datum::Door(p) => {
                target_door = world.grid.get(*p).filter(|o| o.kind == ObjectKind::Door);
                *p
            }
            Datum::Clause { .. } | Datum::Own { .. } => {
                let (kind, targets) = Self::desc_targets(world, datum)
                    .ok_or_else(|| broken("GoNextTo a description the instruction lacks"))?;
                let (obj, pos) = self.planner.find_obj_pos(
                    world,
                    kind,
                    &targets.obj_set,
                    &targets.obj_poss,
                    put_next,
                )?;
                let Some(pos) = pos else {
                    self.stack.push(Subgoal::plain(SubgoalKind::Explore));
                    return Ok(None);
                };
                // `target_obj` is the object paired with `pos`; only a door's state is read.
                target_door = obj
                    .and_then(|id| world.grid.find_id(id))
                    .and_then(|p| world.grid.get(p))
                    .filter(|o| o.kind == ObjectKind::Door);
                pos
            }
        };

        // Walking to a locked door without its key: fetch the key first, unless carrying
        // something that must be brought to the door anyway.
        if top.reason == Some(Reason::Open)
            && let Some(door) = target_door
            && door.state == DoorState::Locked
        {
            let key = Self::key_desc(world, door.color);
            if world.carrying.is_none() {
                let at = world.grid.find_id(door.id).unwrap_or(target_pos);
                self.stack.pop();
                self.stack
                    .push(Subgoal::go_next_to(Datum::Door(at), Some(Reason::Open)));
                self.stack.push(Subgoal::plain(SubgoalKind::Pickup));
                self.stack.push(Subgoal::go_next_to(key, None));
                return Ok(None);
            }
        }

        // Standing on the cell to go next to: step away from it.
        if manhattan(target_pos, pose.pos) == i32::from(put_next) {
            let steppable = |c: Cell| c.is_none() || is_open_door(c);
            if steppable(world.grid.get(pose.fwd_pos)) {
                return Ok(Some(Action::Forward));
            }
            if steppable(world.grid.get(add(pose.pos, pose.right_vec))) {
                return Ok(Some(Action::Right));
            }
            if steppable(world.grid.get(sub(pose.pos, pose.right_vec))) {
                return Ok(Some(Action::Left));
            }
            // Spin and hope for the best.
            return Ok(Some(Action::Left));
        }

        let fwd_cell = world.grid.get(pose.fwd_pos);
        if put_next {
            if manhattan(target_pos, pose.fwd_pos) == 1 {
                if fwd_cell.is_none() {
                    self.stack.pop();
                    return Ok(None);
                }
                if is_open_door(fwd_cell) {
                    // Nothing can be dropped in a doorway: move the target object instead.
                    let beyond = add(pose.fwd_pos, (2 * pose.dir_vec.0, 2 * pose.dir_vec.1));
                    self.stack.push(Subgoal::go_to_pos(Some(beyond)));
                    return Ok(None);
                }
            }
        } else if target_pos == pose.fwd_pos {
            self.stack.pop();
            return Ok(None);
        }

        let mut path = self
            .planner
            .shortest_path(world, &mut |p, _| p == target_pos, false)?;
        if path.first().is_none() {
            path = self
                .planner
                .shortest_path(world, &mut |p, _| p == target_pos, true)?;
        }
        let Some(next_cell) = path.first() else {
            self.stack.push(Subgoal::plain(SubgoalKind::Explore));
            return Ok(None);
        };

        if next_cell == pose.fwd_pos {
            let Some(obj) = fwd_cell else {
                return Ok(Some(Action::Forward));
            };
            if obj.kind == ObjectKind::Door {
                if obj.state == DoorState::Locked {
                    return Err(broken("the door on the path is locked"));
                }
                if obj.state != DoorState::Open {
                    self.stack.push(Subgoal::plain(SubgoalKind::Open));
                    return Ok(None);
                }
                return Ok(Some(Action::Forward));
            }
            // A blocker: move it out of the way.
            if world.carrying.is_some() {
                let drop_pos_cur = self.planner.find_drop_pos(world, None)?;
                let drop_pos_block = self.planner.find_drop_pos(world, drop_pos_cur)?;
                self.stack.push(Subgoal::plain(SubgoalKind::Pickup));
                self.stack.push(Subgoal::go_to_pos(drop_pos_cur));
                self.stack.push(Subgoal::plain(SubgoalKind::Drop));
                self.stack.push(Subgoal::go_to_pos(drop_pos_block));
                self.stack.push(Subgoal::plain(SubgoalKind::Pickup));
                self.stack.push(Subgoal::go_to_pos(Some(pose.fwd_pos)));
                self.stack.push(Subgoal::plain(SubgoalKind::Drop));
                self.stack.push(Subgoal::go_to_pos(drop_pos_cur));
            } else {
                let drop_pos = self.planner.find_drop_pos(world, None)?;
                self.stack.push(Subgoal::plain(SubgoalKind::Drop));
                self.stack.push(Subgoal::go_to_pos(drop_pos));
                self.stack.push(Subgoal::plain(SubgoalKind::Pickup));
            }
            return Ok(None);
        }

        let step = sub(next_cell, pose.pos);
        if step == pose.right_vec {
            return Ok(Some(Action::Right));
        }
        if step == (-pose.right_vec.0, -pose.right_vec.1) {
            return Ok(Some(Action::Left));
        }
        // The next cell is behind: turn towards the side whose wall or door is further.
        let right = closest_wall_or_door(world, pose.pos, pose.right_vec);
        let left = closest_wall_or_door(world, pose.pos, (-pose.right_vec.0, -pose.right_vec.1));
        Ok(Some(if left > right {
            Action::Left
        } else {
            Action::Right
        }))
    }

    fn explore_before(&mut self, world: &World) -> Result<Option<Action>, GiveUp> {
        let (width, height) = (self.planner.width, self.planner.height);
        let vis = self.planner.vis.clone();
        let mut unseen = move |(x, y): Pos, _: Cell| {
            !(x >= 0 && y >= 0 && x < width && y < height && vis[(x * height + y) as usize])
        };
        let unseen_pos = self.planner.shortest_path(world, &mut unseen, true)?.finish;
        if let Some(p) = unseen_pos {
            self.stack.push(Subgoal::go_next_to(
                Datum::Pos(Some(p)),
                Some(Reason::Explore),
            ));
            return Ok(None);
        }
        let closed =
            |c: Cell| c.is_some_and(|o| o.kind == ObjectKind::Door && o.state != DoorState::Open);
        // An unlocked door first: a locked one may be the door an Open subgoal is for.
        let mut door_pos = self
            .planner
            .shortest_path(
                world,
                &mut |_, c| closed(c) && c.is_some_and(|o| o.state != DoorState::Locked),
                true,
            )?
            .finish;
        if door_pos.is_none() {
            door_pos = self
                .planner
                .shortest_path(world, &mut |_, c| closed(c), true)?
                .finish;
        }
        let Some(door_pos) = door_pos else {
            return Err(GiveUp::NothingToExplore);
        };
        let door = world
            .grid
            .get(door_pos)
            .ok_or_else(|| broken("the door to explore is gone"))?;
        let got_the_key = world
            .carrying
            .is_some_and(|c| c.kind == ObjectKind::Key && c.color == door.color);
        let reason = (door.state == DoorState::Locked && got_the_key).then_some(Reason::KeepKey);
        self.stack.pop();
        self.stack
            .push(Subgoal::new(SubgoalKind::Open, None, reason));
        self.stack.push(Subgoal::go_next_to(
            Datum::Door(door_pos),
            Some(Reason::Open),
        ));
        Ok(None)
    }
}
