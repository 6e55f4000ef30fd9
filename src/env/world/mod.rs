//! A BabyAI world and its step function (`MiniGridEnv.step` + `RoomGridLevel.step`
//! + the instruction verifier), ported from minigrid 3.2.0.

use serde::{Deserialize, Serialize};

use super::error::EnvError;
use super::grid::{DIR_TO_VEC, Grid, Pos, Rooms};
use super::instr::{Instr, Status, Verify};
use super::minigrid::Rules;
use super::mission::{Instruction, ObjDesc};
use super::object::{DoorState, ObjectId, ObjectKind, WorldObj};
use super::view::{Observation, observe_seeing};

mod action;

pub use action::Action;

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

/// The full state of one episode: grid, agent, instruction tree and verifier state.
/// Serialises in full (verifier included) for training-state files; the interchange format
/// with Python is [`super::snapshot::Snapshot`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct World {
    /// The world grid (the agent is not in it).
    pub grid: Grid,
    /// The rooms the grid is made of (for location words and room-level analyses).
    pub rooms: Rooms,
    /// Agent position `(x, y)`.
    pub agent_pos: Pos,
    /// Agent direction, 0 = right, 1 = down, 2 = left, 3 = up.
    pub agent_dir: u8,
    /// The carried object, if any.
    pub carrying: Option<WorldObj>,
    /// What each box holds, by the box's id (a key in KeyInBox); opening the box puts it on
    /// the box's cell.
    #[serde(default)]
    pub box_contents: Vec<(ObjectId, WorldObj)>,
    /// Steps taken so far.
    pub step_count: u32,
    /// Truncation horizon.
    pub max_steps: u32,
    /// The instruction tree with its verifier state.
    pub instr: Instr,
    /// The mission text.
    pub mission: String,
    /// BabyAI's done-action mode: `done` succeeds right after a satisfying step, else fails.
    pub done_actions: bool,
    /// Next free object id (for objects added by edits).
    pub next_id: u32,
    /// Python's `cur_pos` of the objects moved since generation (picked up: `(-1, -1)`;
    /// dropped: the drop cell); every other object's is where it stands or stood at reset.
    #[serde(default)]
    pub moved: Vec<(ObjectId, Pos)>,
    /// The PutNext "Carrying" levels observe the world at reset with the carried object still
    /// on this cell (minigrid lifts it after the first observation).
    #[serde(default)]
    pub reset_floor: Option<Pos>,
    /// MiniGrid's `see_through_walls` (Empty, Fetch, GoToDoor, …): the view shows every cell
    /// of its slice, with no visibility sweep. BabyAI's levels never set it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub see_through_walls: bool,
    /// A MiniGrid environment's own step rules (its `step` override); `None` on BabyAI's
    /// levels, where the instruction's verifier decides.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rules: Option<Rules>,
    ended: bool,
}

impl World {
    /// A one-room world at step 0 with a one-clause instruction; resolves the instruction's
    /// matching set at the given pose (`reset_verifier`). Errors if nothing matches or the
    /// agent is on a blocking cell.
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
        let rooms = Rooms::single(grid.width(), grid.height());
        Self::with_tree(
            grid,
            rooms,
            agent_pos,
            agent_dir,
            carrying,
            instr.into(),
            max_steps,
            done_actions,
            next_id,
        )
    }

    /// A world at step 0 with any instruction tree, reset at the given pose.
    #[expect(clippy::too_many_arguments, reason = "mirrors the state a dump holds")]
    pub fn with_tree(
        grid: Grid,
        rooms: Rooms,
        agent_pos: Pos,
        agent_dir: u8,
        carrying: Option<WorldObj>,
        instr: Instr,
        max_steps: u32,
        done_actions: bool,
        next_id: u32,
    ) -> Result<Self, EnvError> {
        let pose = (agent_pos, agent_dir);
        Self::with_tree_among(
            grid,
            rooms,
            pose,
            carrying,
            instr,
            max_steps,
            done_actions,
            next_id,
            None,
        )
    }

    /// [`Self::with_tree`] with the grid's objects (`Grid::objects_but_walls`) already
    /// gathered, where level generation gathered them to validate the instruction.
    #[expect(clippy::too_many_arguments, reason = "mirrors the state a dump holds")]
    pub(crate) fn with_tree_among(
        grid: Grid,
        rooms: Rooms,
        (agent_pos, agent_dir): (Pos, u8),
        carrying: Option<WorldObj>,
        mut instr: Instr,
        max_steps: u32,
        done_actions: bool,
        next_id: u32,
        objects: Option<&[(Pos, WorldObj)]>,
    ) -> Result<Self, EnvError> {
        check_pose(&grid, agent_pos, agent_dir)?;
        match objects {
            Some(objects) => instr.reset_among(objects, &grid, rooms, agent_pos, agent_dir),
            None => instr.reset(&grid, rooms, agent_pos, agent_dir),
        }
        if let Some(clause) = instr.unmatched() {
            return Err(EnvError::InvalidState {
                field: "instr".into(),
                reason: format!("no object matches \"{}\"", clause.surface(1)),
            });
        }
        if max_steps == 0 {
            return Err(EnvError::InvalidState {
                field: "max_steps".into(),
                reason: "must be at least 1".into(),
            });
        }
        let mission = instr.surface();
        Ok(Self {
            grid,
            rooms,
            agent_pos,
            agent_dir,
            carrying,
            box_contents: Vec::new(),
            step_count: 0,
            max_steps,
            instr,
            mission,
            done_actions,
            next_id,
            moved: Vec::new(),
            reset_floor: None,
            see_through_walls: false,
            rules: None,
            ended: false,
        })
    }

    /// A MiniGrid environment's world at step 0: its own `mission` and step `rules`, and an
    /// instruction that describes what the mission names (for the analyses; it decides
    /// nothing), resolved at the agent's pose. Its descriptions may match nothing (Playground).
    #[expect(clippy::too_many_arguments, reason = "mirrors what _gen_grid leaves")]
    pub(crate) fn minigrid(
        grid: Grid,
        rooms: Rooms,
        (agent_pos, agent_dir): (Pos, u8),
        mut instr: Instr,
        mission: String,
        max_steps: u32,
        next_id: u32,
        (rules, see_through_walls): (Rules, bool),
    ) -> Result<Self, EnvError> {
        check_pose(&grid, agent_pos, agent_dir)?;
        instr.reset(&grid, rooms, agent_pos, agent_dir);
        if max_steps == 0 {
            return Err(EnvError::InvalidState {
                field: "max_steps".into(),
                reason: "must be at least 1".into(),
            });
        }
        Ok(Self {
            grid,
            rooms,
            agent_pos,
            agent_dir,
            carrying: None,
            box_contents: Vec::new(),
            step_count: 0,
            max_steps,
            instr,
            mission,
            done_actions: false,
            next_id,
            moved: Vec::new(),
            reset_floor: None,
            see_through_walls,
            rules: Some(rules),
            ended: false,
        })
    }

    /// The first clause's description (the whole instruction on the one-clause levels).
    pub fn desc(&self) -> ObjDesc {
        self.instr.first().instr.desc
    }

    /// The identities of the objects the first clause's description matched.
    pub fn targets(&self) -> &[ObjectId] {
        &self.instr.first().targets.obj_set
    }

    /// Where the first clause's targets are (refreshed after drops, as BabyAI does).
    pub fn target_positions(&self) -> &[Pos] {
        &self.instr.first().targets.obj_poss
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
        if let Some(clause) = self.instr.unmatched()
            && self.rules.is_none()
        {
            return bad(
                "instr",
                format!("no target object for \"{}\"", clause.surface(1)),
            );
        }
        for clause in self.instr.clauses() {
            let poss = clause.targets.obj_poss.iter();
            if let Some(p) = poss
                .chain(&clause.fixed_targets.obj_poss)
                .find(|p| !self.grid.contains(**p))
            {
                return bad("instr.obj_poss", format!("{p:?} is outside the grid"));
            }
        }
        Ok(())
    }

    /// Replaces the instruction (a mission override at step 0): targets are re-resolved at
    /// the current pose and the verifier restarts. Errors if a description matches nothing.
    pub fn set_instruction(&mut self, instr: impl Into<Instr>) -> Result<(), EnvError> {
        if self.rules.is_some() {
            return Err(EnvError::InvalidMission {
                mission: instr.into().surface(),
                reason: "a MiniGrid environment's mission is its own (its step decides, not a \
                         BabyAI instruction): a mission override edits BabyAI levels only"
                    .into(),
            });
        }
        let mut instr = instr.into();
        instr.reset(&self.grid, self.rooms, self.agent_pos, self.agent_dir);
        if let Some(clause) = instr.unmatched() {
            return Err(EnvError::InvalidMission {
                mission: clause.surface(1),
                reason: "no object in this level matches it".into(),
            });
        }
        self.mission = instr.surface();
        self.instr = instr;
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
        if self.step_count == 0
            && let Some(floor) = self.reset_floor
        {
            // minigrid's reset observed the carried object still on the floor.
            let mut grid = self.grid.clone();
            grid.set(floor, self.carrying);
            return observe_seeing(&grid, self.agent_pos, self.agent_dir, None, false);
        }
        observe_seeing(
            &self.grid,
            self.agent_pos,
            self.agent_dir,
            self.carrying,
            self.see_through_walls,
        )
    }

    fn set_moved(&mut self, id: ObjectId, pos: Pos) {
        match self.moved.iter_mut().find(|(o, _)| *o == id) {
            Some(entry) => entry.1 = pos,
            None => self.moved.push((id, pos)),
        }
    }

    /// `1 − 0.9·(t / max_steps)`, in MiniGrid's operation order.
    #[inline]
    pub(crate) fn success_reward(&self) -> f64 {
        1.0 - 0.9 * (f64::from(self.step_count) / f64::from(self.max_steps))
    }

    /// One step. Errors if the episode already ended.
    pub fn step(&mut self, action: Action) -> Result<StepOutcome, EnvError> {
        if self.ended {
            return Err(EnvError::EpisodeEnded {
                step_count: self.step_count,
            });
        }
        if let Some(mut rules) = self.rules.take() {
            let out = rules.step(self, action);
            self.rules = Some(rules);
            self.ended = out.terminated || out.truncated;
            return Ok(out);
        }
        let StepOutcome {
            mut reward,
            mut terminated,
            truncated,
        } = self.base_step(action);
        if action == Action::Drop {
            self.instr.refresh_positions(&self.grid);
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

    /// `MiniGridEnv.step`: the action's effect, the goal's reward and lava's end, truncation.
    pub(crate) fn base_step(&mut self, action: Action) -> StepOutcome {
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
                    self.set_moved(obj.id, (-1, -1));
                }
            }
            Action::Drop => {
                if fwd_cell.is_none()
                    && let Some(obj) = self.carrying.take()
                {
                    self.grid.set(fwd_pos, Some(obj));
                    self.set_moved(obj.id, fwd_pos);
                }
            }
            Action::Toggle => {
                if let Some(mut obj) = fwd_cell {
                    match obj.kind {
                        // The box is replaced by its contents (usually nothing).
                        ObjectKind::Box => {
                            let inside = self
                                .box_contents
                                .iter()
                                .position(|(b, _)| *b == obj.id)
                                .map(|i| self.box_contents.swap_remove(i).1);
                            self.grid.set(fwd_pos, inside);
                        }
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
        StepOutcome {
            reward,
            terminated,
            truncated: self.step_count >= self.max_steps,
        }
    }

    /// `RoomGridLevel.step`'s verification: `Some(true)` success, `Some(false)` failure.
    fn verify(&mut self, action: Action) -> Option<bool> {
        let front = self.front_pos();
        let (moved, grid, floor) = (&self.moved, &self.grid, self.reset_floor);
        let cur_pos = |id| cur_pos_in(moved, grid, floor, id);
        let v = Verify {
            grid: &self.grid,
            front,
            carrying: self.carrying,
            done_actions: self.done_actions,
            cur_pos: &cur_pos,
        };
        let status = self.instr.verify(action, &v);
        match status {
            Status::Success => Some(true),
            Status::Failure => Some(false),
            Status::Continue => None,
        }
    }
}

/// Python's `cur_pos` of object `id` (see [`World::moved`]): where it was last moved to;
/// else where it stands (it has not moved since reset); else, for the object a Carrying level
/// lifted, the floor cell it was placed on.
fn cur_pos_in(
    moved: &[(ObjectId, Pos)],
    grid: &Grid,
    floor: Option<Pos>,
    id: ObjectId,
) -> Option<Pos> {
    moved
        .iter()
        .find(|(o, _)| *o == id)
        .map(|(_, p)| *p)
        .or_else(|| grid.find_id(id))
        .or(floor)
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
mod tests;
