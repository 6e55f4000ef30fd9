//! The bot's subgoals at work: `replan_before_action` and `replan_after_action` of each of
//! minigrid's subgoal classes, as methods of the bot that holds the stack.

use crate::env::{Action, Cell, DoorState, ObjectKind, Pos, World};

use super::super::search::closest_wall_or_door;
use super::super::{Bot, GiveUp, Pose};
use super::{Datum, Reason, Subgoal, SubgoalKind};

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

fn is_open_door(cell: Cell) -> bool {
    cell.is_some_and(|o| o.kind == ObjectKind::Door && o.state == DoorState::Open)
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
    pub(in crate::bot) fn after_action(
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
    pub(in crate::bot) fn before_action(
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
