//! A BabyAI single-room world and its step function (`MiniGridEnv.step` + `RoomGridLevel.step`
//! + the instruction verifier), ported from minigrid 3.2.0.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::error::EnvError;
use super::grid::{DIR_TO_VEC, Grid, Pos};
use super::mission::{Instruction, TaskKind};
use super::object::{DoorState, ObjectKind, WorldObj};
use super::view::{Observation, observe};

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

/// What one step returned.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepOutcome {
    /// `1 − 0.9·t/max_steps` on success, else 0.
    pub reward: f64,
    /// The task succeeded or failed.
    pub terminated: bool,
    /// `step_count ≥ max_steps` (can be true together with `terminated`).
    pub truncated: bool,
}

/// Verifier state of an `ActionInstr` (BabyAI's `verifier.py`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Verifier {
    /// Identities of the matching objects, fixed at reset (`desc.obj_set`).
    pub obj_set: Vec<u32>,
    /// Their positions (`desc.obj_poss`); refreshed only after a `drop`, as BabyAI does.
    pub obj_poss: Vec<Pos>,
    /// `PickupInstr.preCarrying`: id of what was carried after the previous verified step.
    pub pre_carrying: Option<u32>,
    /// `ActionInstr.lastStepMatch`: the previous step satisfied the instruction.
    pub last_step_match: bool,
}

/// The full state of one episode: grid, agent, instruction and verifier.
/// Serialises in full (verifier included) for training-state files; the interchange format
/// with Python is [`super::snapshot::Snapshot`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct World {
    /// The world grid (the agent is not in it).
    pub grid: Grid,
    /// Agent position `(x, y)`.
    pub agent_pos: Pos,
    /// Agent direction, 0 = right, 1 = down, 2 = left, 3 = up.
    pub agent_dir: u8,
    /// The carried object, if any.
    pub carrying: Option<WorldObj>,
    /// Steps taken so far.
    pub step_count: u32,
    /// Truncation horizon.
    pub max_steps: u32,
    /// The instruction.
    pub instr: Instruction,
    /// The mission text.
    pub mission: String,
    /// BabyAI's done-action mode: `done` succeeds right after a satisfying step, else fails.
    pub done_actions: bool,
    /// Verifier state.
    pub verifier: Verifier,
    /// Next free object id (for objects added by edits).
    pub next_id: u32,
    ended: bool,
}

impl World {
    /// A world at step 0; resolves the instruction's matching set at the given pose
    /// (`reset_verifier`). Errors if nothing matches or the agent is on a blocking cell.
    #[expect(clippy::too_many_arguments, reason = "mirrors the state a dump holds")]
    pub fn new(
        grid: Grid,
        agent_pos: Pos,
        agent_dir: u8,
        carrying: Option<WorldObj>,
        instr: Instruction,
        max_steps: u32,
        done_actions: bool,
        next_id: u32,
    ) -> Result<Self, EnvError> {
        check_pose(&grid, agent_pos, agent_dir)?;
        let (obj_set, obj_poss) = instr.desc.find_matching(&grid, agent_pos, agent_dir);
        Self::from_parts(
            grid,
            agent_pos,
            agent_dir,
            carrying,
            instr,
            max_steps,
            done_actions,
            next_id,
            obj_set,
            obj_poss,
        )
    }

    /// A world at step 0 whose targets are the objects at `obj_poss` (as a dump lists them).
    #[expect(clippy::too_many_arguments, reason = "mirrors the state a dump holds")]
    pub fn from_parts(
        grid: Grid,
        agent_pos: Pos,
        agent_dir: u8,
        carrying: Option<WorldObj>,
        instr: Instruction,
        max_steps: u32,
        done_actions: bool,
        next_id: u32,
        obj_set: Vec<u32>,
        obj_poss: Vec<Pos>,
    ) -> Result<Self, EnvError> {
        check_pose(&grid, agent_pos, agent_dir)?;
        if obj_set.is_empty() {
            return Err(EnvError::InvalidState {
                field: "instr".into(),
                reason: format!("no object matches \"{}\"", instr.surface(1)),
            });
        }
        if max_steps == 0 {
            return Err(EnvError::InvalidState {
                field: "max_steps".into(),
                reason: "must be at least 1".into(),
            });
        }
        let mission = instr.surface(obj_set.len());
        Ok(Self {
            grid,
            agent_pos,
            agent_dir,
            carrying,
            step_count: 0,
            max_steps,
            instr,
            mission,
            done_actions,
            verifier: Verifier {
                obj_set,
                obj_poss,
                pre_carrying: None,
                last_step_match: false,
            },
            next_id,
            ended: false,
        })
    }

    /// Checks a world read from a file (a training run's state) for what every method relies
    /// on: a consistent grid, the agent on an enterable cell inside it, a step count within a
    /// positive horizon, and verifier positions inside the grid. Names the first bad field.
    pub fn validate(&self) -> Result<(), EnvError> {
        let bad = |field: &str, reason: String| {
            Err(EnvError::InvalidState {
                field: field.into(),
                reason,
            })
        };
        if !self.grid.is_consistent() {
            return bad(
                "grid",
                format!(
                    "a {}×{} grid needs 1..=256 cells a side and one entry per cell",
                    self.grid.width(),
                    self.grid.height()
                ),
            );
        }
        check_pose(&self.grid, self.agent_pos, self.agent_dir)?;
        if self.max_steps == 0 {
            return bad("max_steps", "must be at least 1".into());
        }
        if self.step_count > self.max_steps {
            return bad(
                "step_count",
                format!("{} is past max_steps {}", self.step_count, self.max_steps),
            );
        }
        if self.verifier.obj_set.is_empty() {
            return bad("verifier.obj_set", "no target object".into());
        }
        if let Some(p) = self
            .verifier
            .obj_poss
            .iter()
            .find(|p| !self.grid.contains(**p))
        {
            return bad("verifier.obj_poss", format!("{p:?} is outside the grid"));
        }
        Ok(())
    }

    /// Replaces the instruction (a mission override at step 0): targets are re-resolved at
    /// the current pose and the verifier restarts. Errors if no object matches.
    pub fn set_instruction(&mut self, instr: Instruction) -> Result<(), EnvError> {
        let (obj_set, obj_poss) =
            instr
                .desc
                .find_matching(&self.grid, self.agent_pos, self.agent_dir);
        if obj_set.is_empty() {
            return Err(EnvError::InvalidMission {
                mission: instr.surface(1),
                reason: "no object in this level matches it".into(),
            });
        }
        self.mission = instr.surface(obj_set.len());
        self.instr = instr;
        self.verifier = Verifier {
            obj_set,
            obj_poss,
            pre_carrying: None,
            last_step_match: false,
        };
        Ok(())
    }

    /// The cell in front of the agent.
    #[inline]
    pub fn front_pos(&self) -> Pos {
        let (dx, dy) = DIR_TO_VEC[usize::from(self.agent_dir)];
        (self.agent_pos.0 + dx, self.agent_pos.1 + dy)
    }

    /// Whether the episode has ended (terminated or truncated).
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// The current egocentric observation.
    #[inline]
    pub fn observe(&self) -> Observation {
        observe(&self.grid, self.agent_pos, self.agent_dir, self.carrying)
    }

    /// `1 − 0.9·(t / max_steps)`, in MiniGrid's operation order.
    #[inline]
    fn success_reward(&self) -> f64 {
        1.0 - 0.9 * (f64::from(self.step_count) / f64::from(self.max_steps))
    }

    /// One step. Errors if the episode already ended.
    pub fn step(&mut self, action: Action) -> Result<StepOutcome, EnvError> {
        if self.ended {
            return Err(EnvError::EpisodeEnded {
                step_count: self.step_count,
            });
        }
        self.step_count += 1;
        let mut reward = 0.0;
        let mut terminated = false;
        let fwd_pos = self.front_pos();
        let fwd_cell = self.grid.get(fwd_pos);
        match action {
            Action::Left => self.agent_dir = (self.agent_dir + 3) % 4,
            Action::Right => self.agent_dir = (self.agent_dir + 1) % 4,
            Action::Forward => {
                if fwd_cell.is_none_or(|c| c.can_overlap()) {
                    self.agent_pos = fwd_pos;
                }
                match fwd_cell.map(|c| c.kind) {
                    Some(ObjectKind::Goal) => {
                        terminated = true;
                        reward = self.success_reward();
                    }
                    Some(ObjectKind::Lava) => terminated = true,
                    _ => {}
                }
            }
            Action::Pickup => {
                if let Some(obj) = fwd_cell
                    && obj.kind.can_pickup()
                    && self.carrying.is_none()
                {
                    self.carrying = Some(obj);
                    self.grid.set(fwd_pos, None);
                }
            }
            Action::Drop => {
                if fwd_cell.is_none()
                    && let Some(obj) = self.carrying.take()
                {
                    self.grid.set(fwd_pos, Some(obj));
                }
            }
            Action::Toggle => {
                if let Some(mut obj) = fwd_cell {
                    match obj.kind {
                        // BabyAI boxes are empty: the box is replaced by its (absent) contents.
                        ObjectKind::Box => self.grid.set(fwd_pos, None),
                        ObjectKind::Door => {
                            obj.state = match obj.state {
                                DoorState::Locked => {
                                    let has_key = self.carrying.is_some_and(|c| {
                                        c.kind == ObjectKind::Key && c.color == obj.color
                                    });
                                    if has_key {
                                        DoorState::Open
                                    } else {
                                        DoorState::Locked
                                    }
                                }
                                DoorState::Open => DoorState::Closed,
                                DoorState::Closed => DoorState::Open,
                            };
                            self.grid.set(fwd_pos, Some(obj));
                        }
                        _ => {}
                    }
                }
            }
            Action::Done => {}
        }
        let truncated = self.step_count >= self.max_steps;
        if action == Action::Drop {
            self.update_objs_poss();
        }
        match self.verify(action) {
            Some(true) => {
                terminated = true;
                reward = self.success_reward();
            }
            Some(false) => {
                terminated = true;
                reward = 0.0;
            }
            None => {}
        }
        self.ended = terminated || truncated;
        Ok(StepOutcome {
            reward,
            terminated,
            truncated,
        })
    }

    /// `find_matching_objs(use_location=False)`: positions of the tracked objects still in
    /// the grid, in scan order.
    fn update_objs_poss(&mut self) {
        let set = &self.verifier.obj_set;
        let poss = &mut self.verifier.obj_poss;
        poss.clear();
        poss.extend(
            self.grid
                .objects()
                .filter(|(_, o)| set.contains(&o.id))
                .map(|(p, _)| p),
        );
    }

    /// `ActionInstr.verify`: `Some(true)` success, `Some(false)` failure, `None` continue.
    fn verify(&mut self, action: Action) -> Option<bool> {
        if !self.done_actions {
            return self.verify_action(action);
        }
        if action == Action::Done {
            return Some(self.verifier.last_step_match);
        }
        let res = self.verify_action(action);
        self.verifier.last_step_match = res == Some(true);
        None
    }

    /// `GoToInstr` / `PickupInstr` `.verify_action`.
    fn verify_action(&mut self, action: Action) -> Option<bool> {
        match self.instr.task {
            TaskKind::GoTo => {
                let front = self.front_pos();
                self.verifier.obj_poss.contains(&front).then_some(true)
            }
            TaskKind::Pickup => {
                let carrying = self.carrying.map(|c| c.id);
                let pre_carrying = std::mem::replace(&mut self.verifier.pre_carrying, carrying);
                if action != Action::Pickup {
                    return None;
                }
                if pre_carrying.is_none()
                    && carrying.is_some_and(|id| self.verifier.obj_set.contains(&id))
                {
                    return Some(true);
                }
                if self.instr.strict && carrying.is_some() {
                    return Some(false);
                }
                None
            }
        }
    }
}

/// The agent must stand inside the grid, on a cell it could enter, facing a real direction.
fn check_pose(grid: &Grid, agent_pos: Pos, agent_dir: u8) -> Result<(), EnvError> {
    let bad = |field: &str, reason: String| {
        Err(EnvError::InvalidState {
            field: field.into(),
            reason,
        })
    };
    if !grid.contains(agent_pos) {
        return bad(
            "agent_pos",
            format!(
                "{agent_pos:?} is outside the {}×{} grid",
                grid.width(),
                grid.height()
            ),
        );
    }
    if agent_dir > 3 {
        return bad(
            "agent_dir",
            format!("{agent_dir} is not a direction (0..=3)"),
        );
    }
    if let Some(obj) = grid.get(agent_pos)
        && !obj.can_overlap()
    {
        return bad(
            "agent_pos",
            format!("the agent at {agent_pos:?} stands on a {}", obj.describe()),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::mission::ObjDesc;
    use crate::env::object::Color;

    /// A 5×5 room, agent at (1, 2) facing right, a red ball at (2, 2) and a blue key at (3, 1).
    fn room(task: TaskKind, done_actions: bool) -> World {
        let mut grid = Grid::new(5, 5);
        let mut id = 0;
        grid.wall_ring(&mut id);
        grid.set(
            (2, 2),
            Some(WorldObj::new(ObjectKind::Ball, Color::Red, 100)),
        );
        grid.set(
            (3, 1),
            Some(WorldObj::new(ObjectKind::Key, Color::Blue, 101)),
        );
        let instr = Instruction {
            task,
            desc: ObjDesc {
                kind: Some(ObjectKind::Key),
                color: Some(Color::Blue),
                loc: None,
            },
            strict: false,
        };
        World::new(grid, (1, 2), 0, None, instr, 25, done_actions, 200).unwrap()
    }

    #[test]
    fn forward_into_an_object_is_blocked_but_consumes_a_step() {
        let mut w = room(TaskKind::GoTo, false);
        let out = w.step(Action::Forward).unwrap();
        assert_eq!((w.agent_pos, w.step_count, out.reward), ((1, 2), 1, 0.0));
    }

    #[test]
    fn drop_onto_a_non_empty_cell_does_nothing() {
        let mut w = room(TaskKind::GoTo, false);
        w.step(Action::Pickup).unwrap();
        assert_eq!(w.carrying.map(|c| c.id), Some(100));
        w.step(Action::Right).unwrap(); // face (1, 3): empty
        w.step(Action::Left).unwrap();
        w.step(Action::Left).unwrap(); // face (1, 1): empty
        w.step(Action::Left).unwrap(); // face (0, 2): wall
        w.step(Action::Drop).unwrap();
        assert_eq!(
            w.carrying.map(|c| c.id),
            Some(100),
            "cannot drop onto a wall"
        );
        w.step(Action::Left).unwrap(); // face (1, 3) again: empty
        w.step(Action::Drop).unwrap();
        assert_eq!(w.carrying, None);
        assert_eq!(w.grid.get((1, 3)).map(|o| o.id), Some(100));
    }

    #[test]
    fn turning_to_face_the_target_succeeds_without_done() {
        let mut w = room(TaskKind::GoTo, false);
        w.step(Action::Pickup).unwrap(); // clear the ball (a wrong pickup is harmless)
        w.step(Action::Forward).unwrap(); // to (2, 2)
        let out = w.step(Action::Forward).unwrap(); // to (3, 2): facing right, key is up
        assert!(!out.terminated);
        let out = w.step(Action::Left).unwrap(); // face up → (3, 1): the blue key
        assert!(out.terminated && out.reward > 0.0);
        assert_eq!(out.reward, 1.0 - 0.9 * (4.0 / 25.0));
        assert!(w.step(Action::Done).is_err(), "no stepping after the end");
    }

    #[test]
    fn done_mode_needs_done_right_after_a_satisfying_step() {
        let mut w = room(TaskKind::GoTo, true);
        for a in [
            Action::Pickup,
            Action::Forward,
            Action::Forward,
            Action::Left,
        ] {
            assert!(
                !w.step(a).unwrap().terminated,
                "facing the target is not enough"
            );
        }
        let out = w.step(Action::Done).unwrap();
        assert!(out.terminated && out.reward > 0.0);
        // An early done fails with reward 0.
        let mut w = room(TaskKind::GoTo, true);
        let out = w.step(Action::Done).unwrap();
        assert!(out.terminated && out.reward == 0.0);
    }

    #[test]
    fn pickup_needs_the_target_object_and_box_toggle_deletes_it() {
        let mut w = room(TaskKind::Pickup, false);
        assert!(
            !w.step(Action::Pickup).unwrap().terminated,
            "the ball is not the target"
        );
        w.step(Action::Forward).unwrap();
        w.step(Action::Forward).unwrap();
        w.step(Action::Left).unwrap();
        assert!(
            !w.step(Action::Pickup).unwrap().terminated,
            "hands full: the key stays"
        );
        w.step(Action::Right).unwrap();
        w.step(Action::Drop).unwrap(); // ball onto (4, 2)? wall: nothing
        w.step(Action::Right).unwrap(); // face (3, 3): empty
        w.step(Action::Drop).unwrap();
        w.step(Action::Left).unwrap();
        w.step(Action::Left).unwrap(); // face the key
        let out = w.step(Action::Pickup).unwrap();
        assert!(out.terminated && out.reward > 0.0);

        let mut grid = Grid::new(5, 5);
        let mut id = 0;
        grid.wall_ring(&mut id);
        grid.set(
            (2, 2),
            Some(WorldObj::new(ObjectKind::Box, Color::Green, 50)),
        );
        let instr = Instruction {
            task: TaskKind::Pickup,
            desc: ObjDesc {
                kind: Some(ObjectKind::Box),
                color: None,
                loc: None,
            },
            strict: false,
        };
        let mut w = World::new(grid, (1, 2), 0, None, instr, 25, false, 60).unwrap();
        w.step(Action::Toggle).unwrap();
        assert_eq!(w.grid.get((2, 2)), None, "toggling a box deletes it");
    }
}
