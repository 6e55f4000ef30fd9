//! The evidence BabyAI's mechanics leave in an episode — rooms entered, doors opened, keys
//! carried, objects acted on out of order, an object put down beside the wrong one — and the
//! failure classes it decides ([`super::FailureClass`], rules 1–3 and 6–8 of the module's
//! list). On a one-room level without doors, sequences or PutNext nothing here ever fires.

use crate::env::grid::Pos;
use crate::env::mission::TaskKind;
use crate::env::object::{Color, DoorState, ObjectId, ObjectKind};
use crate::env::roles::{future_clauses, pending_clauses};
use crate::env::world::{Action, World};

use super::{FailureClass, StepFacts};

/// A room `(i, j)` of the level's room grid.
type Room = (i32, i32);

/// What an episode showed of doors, rooms, sequences and PutNext.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mechanics {
    /// Rooms the agent stood in (a doorway counts for both rooms it joins).
    pub rooms_entered: Vec<Room>,
    /// Doors seen open at some step.
    pub doors_opened: Vec<ObjectId>,
    /// Colours of the keys the agent carried.
    pub keys_carried: Vec<Color>,
    /// The agent picked up or opened an object of a clause the sequence had not reached.
    pub wrong_order: bool,
    /// The agent put the object to move down beside other objects, none of them one its
    /// PutNext named.
    pub wrong_neighbour: bool,
    /// The step of the first such act, out of order or beside the wrong object: where the
    /// episode was lost.
    pub wrong_step: Option<u32>,
    /// At the last step: the rooms holding the objects the verifier was waiting on.
    pub target_rooms: Vec<Room>,
    /// At the last step: those rooms' doors — id, colour, locked.
    pub target_room_doors: Vec<(ObjectId, Color, bool)>,
    /// At the last step: the doors of the Open clauses the verifier was waiting on.
    pub open_targets: Vec<ObjectId>,
}

/// The rooms of `world` whose square (walls included) holds `pos`.
pub(super) fn rooms_at(world: &World, pos: Pos) -> impl Iterator<Item = Room> + '_ {
    let r = world.rooms;
    (0..r.num_cols)
        .flat_map(move |i| (0..r.num_rows).map(move |j| (i, j)))
        .filter(move |&room| r.pos_inside(room, pos))
}

fn add<T: PartialEq>(v: &mut Vec<T>, x: T) {
    if !v.contains(&x) {
        v.push(x);
    }
}

impl Mechanics {
    /// Adds one step.
    pub fn push(&mut self, step: &StepFacts<'_>) {
        let w = step.world;
        let multi_room = w.rooms.num_cols * w.rooms.num_rows > 1;
        if multi_room {
            for room in rooms_at(w, w.agent_pos) {
                add(&mut self.rooms_entered, room);
            }
            for (_, o) in w.grid.objects() {
                if o.kind == ObjectKind::Door && o.state == DoorState::Open {
                    add(&mut self.doors_opened, o.id);
                }
            }
        }
        if let Some(o) = w.carrying.filter(|o| o.kind == ObjectKind::Key) {
            add(&mut self.keys_carried, o.color);
        }
        let front = w.grid.get(w.front_pos());
        if let (Some(o), Action::Pickup | Action::Toggle) = (front, step.action) {
            let clauses = w.instr.clauses();
            let wrong = future_clauses(&w.instr).into_iter().any(|c| {
                clauses.get(c).is_some_and(|n| {
                    let acts = matches!(
                        (n.instr.task, step.action),
                        (TaskKind::Pickup | TaskKind::PutNext, Action::Pickup)
                            | (TaskKind::Open, Action::Toggle)
                    );
                    acts && n.targets.obj_set.contains(&o.id)
                })
            });
            self.wrong_order |= wrong;
            self.note_wrong(wrong, w.step_count);
        }
        if let (Some(m), Action::Drop, None) = (w.carrying, step.action, front) {
            let (fx, fy) = w.front_pos();
            let beside: Vec<ObjectId> = [(1, 0), (-1, 0), (0, 1), (0, -1)]
                .into_iter()
                .filter_map(|(dx, dy)| w.grid.get((fx + dx, fy + dy)))
                .filter(|o| o.kind.can_pickup())
                .map(|o| o.id)
                .collect();
            let clauses = w.instr.clauses();
            let wrong = pending_clauses(&w.instr).into_iter().any(|c| {
                clauses.get(c).is_some_and(|n| {
                    n.instr.task == TaskKind::PutNext
                        && n.targets.obj_set.contains(&m.id)
                        && !beside.is_empty()
                        && !beside.iter().any(|id| n.fixed_targets.obj_set.contains(id))
                })
            });
            self.wrong_neighbour |= wrong;
            self.note_wrong(wrong, w.step_count);
        }
        if step.terminated || step.truncated {
            self.end(w, multi_room);
        }
    }

    /// Keeps `step` as [`Self::wrong_step`] if the act there was wrong and none was before.
    fn note_wrong(&mut self, wrong: bool, step: u32) {
        if wrong && self.wrong_step.is_none() {
            self.wrong_step = Some(step);
        }
    }

    /// Notes what the verifier was waiting on at the last step.
    fn end(&mut self, w: &World, multi_room: bool) {
        // BabyAI's doors all join rooms: a one-room level has none.
        if !multi_room {
            return;
        }
        let clauses = w.instr.clauses();
        let pending: Vec<_> = pending_clauses(&w.instr)
            .into_iter()
            .filter_map(|c| clauses.get(c).copied())
            .collect();
        self.open_targets = pending
            .iter()
            .filter(|n| n.instr.task == TaskKind::Open)
            .flat_map(|n| n.targets.obj_set.iter().copied())
            .collect();
        let ids = crate::env::tree::pending_target_ids(w);
        for (p, o) in w.grid.objects() {
            // A door's own rooms are the two it joins, one of which the agent is in.
            if ids.contains(&o.id) && o.kind != ObjectKind::Door {
                for room in rooms_at(w, p) {
                    add(&mut self.target_rooms, room);
                }
            }
        }
        for (p, o) in w.grid.objects() {
            if o.kind == ObjectKind::Door && rooms_at(w, p).any(|r| self.target_rooms.contains(&r))
            {
                add(
                    &mut self.target_room_doors,
                    (o.id, o.color, o.state == DoorState::Locked),
                );
            }
        }
    }

    /// Rules 1–3: the objects waited on lie only in rooms the agent never entered — behind a
    /// locked door whose key it never carried, behind doors it never opened, or neither.
    pub fn room_class(&self) -> Option<FailureClass> {
        if self.target_rooms.is_empty()
            || self
                .target_rooms
                .iter()
                .any(|r| self.rooms_entered.contains(r))
        {
            return None;
        }
        let closed: Vec<_> = self
            .target_room_doors
            .iter()
            .filter(|(id, ..)| !self.doors_opened.contains(id))
            .collect();
        let all_closed =
            !self.target_room_doors.is_empty() && closed.len() == self.target_room_doors.len();
        Some(if !all_closed {
            FailureClass::TargetRoomNeverEntered
        } else if closed
            .iter()
            .any(|(_, color, locked)| *locked && !self.keys_carried.contains(color))
        {
            FailureClass::LockedDoorNoKey
        } else {
            FailureClass::DoorNeverOpened
        })
    }

    /// Rules 6–8: a clause acted on out of order, an object put beside the wrong one, or a
    /// door to open that never was.
    pub fn act_class(&self) -> Option<FailureClass> {
        if self.wrong_order {
            Some(FailureClass::WrongOrder)
        } else if self.wrong_neighbour {
            Some(FailureClass::WrongNeighbour)
        } else if !self.open_targets.is_empty()
            && self
                .open_targets
                .iter()
                .all(|id| !self.doors_opened.contains(id))
        {
            Some(FailureClass::DoorNeverOpened)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Evidence, FailureClass, StepFacts};
    use crate::env::level::{LevelConfig, LevelId};
    use crate::env::world::{Action, World};

    /// Runs `world` with `actions` (then turning left to the end) and classifies it, as the
    /// sweep does, without `M`.
    fn classify(world: World, actions: &[Action]) -> Option<FailureClass> {
        diagnose(world, actions, Action::Left).map(|d| d.class)
    }

    /// Runs `world` with `actions`, then `then` to the end, and diagnoses it without `M`.
    fn diagnose(
        mut world: World,
        actions: &[Action],
        then: Action,
    ) -> Option<super::super::Diagnosis> {
        let mut e = Evidence::default();
        let mut t = 0;
        while !world.ended() {
            let action = actions.get(t).copied().unwrap_or(then);
            t += 1;
            let obs = world.observe();
            let before = world.clone();
            let out = world.step(action).unwrap();
            e.push(&StepFacts {
                world: &before,
                obs: &obs,
                combined: None,
                action,
                reward: out.reward,
                terminated: out.terminated,
                truncated: out.truncated,
            });
        }
        e.diagnose()
    }

    /// The class says what the agent never reached, the behaviour what it did instead:
    /// turning until the limit behind KeyCorridor's locked door is `locked_door_no_key` by
    /// class and `turning_in_place` by behaviour; walking into the wall ahead to the limit is
    /// `blocked_forward` by behaviour (its class unchanged).
    #[test]
    fn the_behaviour_names_what_the_agent_did() {
        for seed in 0..3 {
            let world = babyai("BabyAI-KeyCorridorS3R3-v0").generate(seed).unwrap();
            let d = diagnose(world.clone(), &[], Action::Left).unwrap();
            assert_eq!(d.class, FailureClass::LockedDoorNoKey);
            assert_eq!(d.behaviour, Some(FailureClass::TurningInPlace));
            let d = diagnose(world, &[], Action::Forward).unwrap();
            assert_eq!(d.class, FailureClass::LockedDoorNoKey, "seed {seed}");
            assert_eq!(
                d.behaviour,
                Some(FailureClass::BlockedForward),
                "seed {seed}"
            );
        }
    }

    /// Pressing `pickup` into a wall to the limit is `repeated_no_op`; going round a loop
    /// (right, forward, right, forward) is `cycling`; neither changes the class.
    #[test]
    fn presses_that_change_nothing_and_loops_are_behaviours() {
        for seed in 0..3 {
            let world = babyai("BabyAI-KeyCorridorS3R3-v0").generate(seed).unwrap();
            let d = diagnose(world.clone(), &[], Action::Pickup).unwrap();
            assert_eq!(d.class, FailureClass::LockedDoorNoKey, "seed {seed}");
            assert_eq!(d.behaviour, Some(FailureClass::RepeatedNoOp), "seed {seed}");
            let loop_: Vec<Action> = (0..world.max_steps)
                .map(|t| {
                    if t % 2 == 0 {
                        Action::Right
                    } else {
                        Action::Forward
                    }
                })
                .collect();
            let d = diagnose(world, &loop_, Action::Right).unwrap();
            assert_eq!(d.behaviour, Some(FailureClass::Cycling), "seed {seed}");
        }
        // A pickup in front of an object can change something: not a no-op.
        let mut world = babyai("BabyAI-PickupLoc-v0").generate(0).unwrap();
        let obj = crate::env::object::WorldObj::new(
            crate::env::object::ObjectKind::Ball,
            crate::env::object::Color::Red,
            99,
        );
        let front = world.front_pos();
        world.grid.set(front, Some(obj));
        assert!(!super::super::no_op_press(&world, Action::Pickup));
        assert!(super::super::no_op_press(&world, Action::Drop));
        assert!(super::super::no_op_press(&world, Action::Toggle));
    }

    fn babyai(id: &str) -> LevelConfig {
        LevelConfig {
            babyai: Some(LevelId::parse(id).unwrap()),
            done_required: false,
            ..LevelConfig::default()
        }
    }

    #[test]
    fn a_target_behind_a_locked_door_whose_key_was_never_held() {
        // KeyCorridor's ball is in the locked room: an agent that only turns never gets there.
        for seed in 0..5 {
            let world = babyai("BabyAI-KeyCorridorS3R3-v0").generate(seed).unwrap();
            assert_eq!(
                classify(world, &[]),
                Some(FailureClass::LockedDoorNoKey),
                "seed {seed}"
            );
        }
    }

    #[test]
    fn a_target_behind_closed_doors_and_one_in_view_is_not_a_room_failure() {
        let mut rooms = 0;
        for seed in 0..20 {
            let world = babyai("BabyAI-GoToObjMazeS4-v0").generate(seed).unwrap();
            let start = world.rooms.room_of(world.agent_pos);
            let target = world.instr.first().targets.obj_poss[0];
            let class = classify(world.clone(), &[]);
            if world.rooms.room_of(target) == start {
                assert!(
                    !matches!(
                        class,
                        Some(
                            FailureClass::DoorNeverOpened
                                | FailureClass::TargetRoomNeverEntered
                                | FailureClass::LockedDoorNoKey
                        )
                    ),
                    "seed {seed}: {class:?}"
                );
            } else if class == Some(FailureClass::DoorNeverOpened) {
                rooms += 1;
            }
        }
        assert!(rooms >= 3, "{rooms} episodes behind closed doors");
    }

    #[test]
    fn picking_up_the_later_clauses_object_first_is_the_wrong_order() {
        use crate::env::mission::{Instruction, ObjDesc, TaskKind};
        use crate::env::{Instr, SeqKind};
        let (mut made, mut located) = (0, 0);
        for seed in 0..40 {
            let mut world = LevelConfig::default().generate(seed).unwrap();
            // Stand beside an object, facing it (BabyAI never places one next to the agent).
            let Some((pos, dir, front)) = world.grid.objects().find_map(|(p, o)| {
                let free = |q: crate::env::grid::Pos| world.grid.get(q).is_none();
                o.kind.can_pickup().then_some(())?;
                (0u8..4).find_map(|dir| {
                    let (dx, dy) = crate::env::grid::DIR_TO_VEC[usize::from(dir)];
                    let at = (p.0 - dx, p.1 - dy);
                    free(at).then_some((at, dir, o))
                })
            }) else {
                continue;
            };
            (world.agent_pos, world.agent_dir) = (pos, dir);
            let desc = |o: crate::env::object::WorldObj| ObjDesc {
                kind: Some(o.kind),
                color: Some(o.color),
                loc: None,
            };
            let Some((_, other)) = world.grid.objects().find(|(_, o)| {
                o.kind.can_pickup() && (o.kind, o.color) != (front.kind, front.color)
            }) else {
                continue;
            };
            // "go to OTHER, then pick up FRONT": picking FRONT up at once is out of order.
            let tree = Instr::seq(
                SeqKind::Before,
                Instruction::new(TaskKind::GoTo, desc(other)).into(),
                Instruction::new(TaskKind::Pickup, desc(front)).into(),
            );
            world.set_instruction(tree).unwrap();
            world.done_actions = false;
            // Looking away and back first: the early pickup, at step 2, is where it was lost
            // (unless the look away faced OTHER, doing the first clause).
            if let Some(d) = diagnose(
                world.clone(),
                &[Action::Left, Action::Right, Action::Pickup],
                Action::Left,
            ) {
                assert_eq!(d.behaviour, Some(FailureClass::WrongOrder), "seed {seed}");
                assert_eq!(d.lost_at, Some(2), "seed {seed}");
                located += 1;
            }
            let class = classify(world, &[Action::Pickup]);
            if class == Some(FailureClass::TargetNeverVisible) {
                continue; // the first clause's object never came into view: rule 4 first
            }
            assert_eq!(class, Some(FailureClass::WrongOrder), "seed {seed}");
            made += 1;
        }
        assert!(made >= 10 && located >= 10, "{made}, {located}");
    }
}
