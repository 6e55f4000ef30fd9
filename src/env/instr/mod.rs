//! BabyAI's instruction trees and their verifiers (`verifier.py`): action clauses (GoTo,
//! Pickup, Open, PutNext) and the sequences And, Before and After, each node with the state
//! its Python class keeps between steps.
//!
//! The port keeps Python's quirks, because an agent trained in minigrid met them:
//! - a clause's matched objects are fixed at reset; their positions are refreshed only after a
//!   `drop` (GoTo still succeeds in front of where a picked-up target stood);
//! - in done-action mode a clause answers only on `done`, and `And` never fails on `done`
//!   (its check reads `action is actions.done`, false for the ints gym passes);
//! - a clause nested in Before / After keeps its `preCarrying` from the last step it was
//!   asked about, not the last step of the episode;
//! - PutNext reads the moved object's `cur_pos`, which a failed drop leaves where Python last
//!   set it (see [`Verify::cur_pos`]).

use serde::{Deserialize, Serialize};

use super::error::EnvError;
use super::grid::{Grid, Pos, Rooms};
use super::mission::{Instruction, ObjDesc, ParseError, TaskKind};
use super::object::{DoorState, ObjectId, ObjectKind, WorldObj};
use super::world::Action;

/// A verifier's answer for one step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Neither success nor failure yet (Python's `"continue"`, `None` and `False`).
    #[default]
    Continue,
    /// The instruction is satisfied.
    Success,
    /// The episode fails.
    Failure,
}

/// The objects a description matched at reset (`obj_set`) and where they are
/// (`obj_poss`, refreshed only after a drop).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Targets {
    /// Identities, in scan order.
    pub obj_set: Vec<ObjectId>,
    /// Positions of those still on the grid.
    pub obj_poss: Vec<Pos>,
    /// The agent's pose the description was resolved at, where it has a location word
    /// ("on your left" is a half-plane of that pose, fixed at reset).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose: Option<(Pos, u8)>,
}

impl Targets {
    /// `find_matching_objs(use_location=True)`.
    pub fn find(desc: ObjDesc, grid: &Grid, rooms: Rooms, agent_pos: Pos, agent_dir: u8) -> Self {
        let (obj_set, obj_poss) = desc.find_matching(grid, rooms, agent_pos, agent_dir);
        Self {
            obj_set,
            obj_poss,
            pose: desc.loc.map(|_| (agent_pos, agent_dir)),
        }
    }

    /// [`Self::find`] among the grid's objects gathered once ([`ObjDesc::find_matching_among`]).
    pub(crate) fn find_among(
        desc: ObjDesc,
        objects: &[(Pos, WorldObj)],
        grid: &Grid,
        rooms: Rooms,
        (agent_pos, agent_dir): (Pos, u8),
    ) -> Self {
        let (obj_set, obj_poss) =
            desc.find_matching_among(objects, grid, rooms, agent_pos, agent_dir);
        Self {
            obj_set,
            obj_poss,
            pose: desc.loc.map(|_| (agent_pos, agent_dir)),
        }
    }

    /// `find_matching_objs(use_location=False)`: the tracked objects' positions, scan order.
    fn refresh(&mut self, desc: ObjDesc, grid: &Grid) {
        self.obj_poss.clear();
        for (p, o) in grid.objects() {
            if self.obj_set.contains(&o.id) && desc.matches(&o) {
                self.obj_poss.push(p);
            }
        }
    }
}

/// One action clause with its verifier state.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ActionNode {
    /// What to do.
    pub instr: Instruction,
    /// What `desc` matched (PutNext: the objects to move).
    pub targets: Targets,
    /// What PutNext's `fixed` description matched (empty for other clauses).
    #[serde(default)]
    pub fixed_targets: Targets,
    /// `preCarrying`: what was carried when the clause was last asked.
    pub pre_carrying: Option<ObjectId>,
    /// `lastStepMatch` (done-action mode).
    pub last_step_match: bool,
}

/// How a sequence orders its two parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SeqKind {
    /// `AndInstr`: both, in any order.
    And,
    /// `BeforeInstr`: `a`, then `b`.
    Before,
    /// `AfterInstr`: `a` after `b` (so `b` first).
    After,
}

impl SeqKind {
    /// The class name the Python dumps use.
    pub fn instr_class(self) -> &'static str {
        match self {
            Self::And => "AndInstr",
            Self::Before => "BeforeInstr",
            Self::After => "AfterInstr",
        }
    }

    /// The kind with class name `name`, if any.
    pub fn from_class(name: &str) -> Option<Self> {
        [Self::And, Self::Before, Self::After]
            .into_iter()
            .find(|k| k.instr_class() == name)
    }

    /// The words joining the two parts' surfaces.
    fn joiner(self) -> &'static str {
        match self {
            Self::And => " and ",
            Self::Before => ", then ",
            Self::After => " after you ",
        }
    }
}

/// Two instructions in sequence, with the parts' last answers.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SeqNode {
    /// And, Before or After.
    pub kind: SeqKind,
    /// The first part as written.
    pub a: Instr,
    /// The second part as written.
    pub b: Instr,
    /// `strict`: doing the later part first fails (no registered level sets it).
    pub strict: bool,
    /// `a_done`.
    pub a_done: Status,
    /// `b_done`.
    pub b_done: Status,
}

/// A BabyAI instruction: one clause or a sequence of two.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Instr {
    /// GoTo, Pickup, Open or PutNext.
    Action(ActionNode),
    /// And, Before or After.
    Seq(Box<SeqNode>),
}

/// What a verifier reads of the world after a step.
pub(crate) struct Verify<'a> {
    /// The grid after the step.
    pub grid: &'a Grid,
    /// The cell in front of the agent.
    pub front: Pos,
    /// The carried object after the step.
    pub carrying: Option<WorldObj>,
    /// BabyAI's done-action mode.
    pub done_actions: bool,
    /// Python's `obj.cur_pos` for an object: set when placed, `(-1, -1)` when picked up, the
    /// drop cell when dropped; not updated when a level lifts an object into the agent's
    /// hands or a box is opened.
    pub cur_pos: &'a dyn Fn(ObjectId) -> Option<Pos>,
}

impl From<Instruction> for Instr {
    fn from(instr: Instruction) -> Self {
        Self::Action(ActionNode {
            instr,
            targets: Targets::default(),
            fixed_targets: Targets::default(),
            pre_carrying: None,
            last_step_match: false,
        })
    }
}

impl Instr {
    /// A sequence of two instructions.
    pub fn seq(kind: SeqKind, a: Instr, b: Instr) -> Self {
        Self::Seq(Box::new(SeqNode {
            kind,
            a,
            b,
            strict: false,
            a_done: Status::Continue,
            b_done: Status::Continue,
        }))
    }

    /// `reset_verifier`: resolves every description at the agent's pose and clears the
    /// per-step state of the sequences and of Pickup / PutNext (`lastStepMatch` is kept, as
    /// Python keeps it).
    pub fn reset(&mut self, grid: &Grid, rooms: Rooms, agent_pos: Pos, agent_dir: u8) {
        let objects = grid.objects_but_walls();
        self.reset_among(&objects, grid, rooms, agent_pos, agent_dir);
    }

    /// [`Self::reset`] with the grid's objects gathered once for every clause.
    pub(crate) fn reset_among(
        &mut self,
        objects: &[(Pos, WorldObj)],
        grid: &Grid,
        rooms: Rooms,
        agent_pos: Pos,
        agent_dir: u8,
    ) {
        let find = |desc| Targets::find_among(desc, objects, grid, rooms, (agent_pos, agent_dir));
        match self {
            Self::Action(n) => {
                n.targets = find(n.instr.desc);
                n.fixed_targets = n.instr.fixed.map(find).unwrap_or_default();
                n.pre_carrying = None;
            }
            Self::Seq(s) => {
                s.a.reset_among(objects, grid, rooms, agent_pos, agent_dir);
                s.b.reset_among(objects, grid, rooms, agent_pos, agent_dir);
                s.a_done = Status::Continue;
                s.b_done = Status::Continue;
            }
        }
    }

    /// The mission text, from the matches of the last reset ("the" iff one object matched).
    pub fn surface(&self) -> String {
        let mut s = String::with_capacity(128);
        self.push_surface(&mut s);
        s
    }

    /// [`Self::surface`] appended to `out`.
    fn push_surface(&self, out: &mut String) {
        match self {
            Self::Action(n) => n.instr.push_surface_with(
                n.targets.obj_set.len(),
                n.fixed_targets.obj_set.len(),
                out,
            ),
            Self::Seq(s) => {
                s.a.push_surface(out);
                out.push_str(s.kind.joiner());
                s.b.push_surface(out);
            }
        }
    }

    /// The first description that matches nothing, if any (such an instruction has no
    /// surface in BabyAI: `surface` asserts).
    pub fn unmatched(&self) -> Option<&Instruction> {
        match self {
            Self::Action(n) => (n.targets.obj_set.is_empty()
                || (n.instr.fixed.is_some() && n.fixed_targets.obj_set.is_empty()))
            .then_some(&n.instr),
            Self::Seq(s) => s.a.unmatched().or_else(|| s.b.unmatched()),
        }
    }

    /// The action clauses, in reading order.
    pub fn clauses(&self) -> Vec<&ActionNode> {
        let mut out = Vec::new();
        self.collect(&mut out);
        out
    }

    fn collect<'a>(&'a self, out: &mut Vec<&'a ActionNode>) {
        match self {
            Self::Action(n) => out.push(n),
            Self::Seq(s) => {
                s.a.collect(out);
                s.b.collect(out);
            }
        }
    }

    /// The action clauses, in reading order, to edit (their matches are stale until the next
    /// [`Self::reset`]).
    pub fn clauses_mut(&mut self) -> Vec<&mut ActionNode> {
        match self {
            Self::Action(n) => vec![n],
            Self::Seq(s) => {
                let mut v = s.a.clauses_mut();
                v.extend(s.b.clauses_mut());
                v
            }
        }
    }

    /// The first clause in reading order.
    pub fn first(&self) -> &ActionNode {
        match self {
            Self::Action(n) => n,
            Self::Seq(s) => s.a.first(),
        }
    }

    /// `num_navs_needed`: PutNext 2, other clauses 1, sequences the sum.
    pub fn num_navs(&self) -> u32 {
        match self {
            Self::Action(n) if n.instr.task == TaskKind::PutNext => 2,
            Self::Action(_) => 1,
            Self::Seq(s) => s.a.num_navs() + s.b.num_navs(),
        }
    }

    /// `update_objs_poss` after a drop, on every clause.
    pub(crate) fn refresh_positions(&mut self, grid: &Grid) {
        match self {
            Self::Action(n) => {
                n.targets.refresh(n.instr.desc, grid);
                if let Some(f) = n.instr.fixed {
                    n.fixed_targets.refresh(f, grid);
                }
            }
            Self::Seq(s) => {
                s.a.refresh_positions(grid);
                s.b.refresh_positions(grid);
            }
        }
    }

    /// `verify(action)` after a step.
    pub(crate) fn verify(&mut self, action: Action, v: &Verify<'_>) -> Status {
        match self {
            Self::Action(n) => n.verify(action, v),
            Self::Seq(s) => s.verify(action, v),
        }
    }
}

impl ActionNode {
    /// `ActionInstr.verify`.
    fn verify(&mut self, action: Action, v: &Verify<'_>) -> Status {
        if !v.done_actions {
            return self.verify_action(action, v);
        }
        if action == Action::Done {
            return if self.last_step_match {
                Status::Success
            } else {
                Status::Failure
            };
        }
        self.last_step_match = self.verify_action(action, v) == Status::Success;
        Status::Continue
    }

    /// `verify_action` of GoTo, Pickup, Open and PutNext.
    fn verify_action(&mut self, action: Action, v: &Verify<'_>) -> Status {
        match self.instr.task {
            TaskKind::GoTo => {
                if self.targets.obj_poss.contains(&v.front) {
                    Status::Success
                } else {
                    Status::Continue
                }
            }
            TaskKind::Pickup => {
                let carrying = v.carrying.map(|c| c.id);
                let pre = std::mem::replace(&mut self.pre_carrying, carrying);
                if action != Action::Pickup {
                    return Status::Continue;
                }
                if pre.is_none() && carrying.is_some_and(|id| self.targets.obj_set.contains(&id)) {
                    return Status::Success;
                }
                if self.instr.strict && carrying.is_some() {
                    return Status::Failure;
                }
                Status::Continue
            }
            TaskKind::Open => {
                if action != Action::Toggle {
                    return Status::Continue;
                }
                let front = v.grid.get(v.front);
                if let Some(door) = front
                    && self.targets.obj_set.contains(&door.id)
                    && door.state == DoorState::Open
                {
                    return Status::Success;
                }
                if self.instr.strict && front.is_some_and(|o| o.kind == ObjectKind::Door) {
                    return Status::Failure;
                }
                Status::Continue
            }
            TaskKind::PutNext => {
                let carrying = v.carrying.map(|c| c.id);
                let pre = std::mem::replace(&mut self.pre_carrying, carrying);
                if self.instr.strict && action == Action::Pickup && carrying.is_some() {
                    return Status::Failure;
                }
                if action != Action::Drop {
                    return Status::Continue;
                }
                let Some(moved) = pre.filter(|id| self.targets.obj_set.contains(id)) else {
                    return Status::Continue;
                };
                let Some(a) = (v.cur_pos)(moved) else {
                    return Status::Continue;
                };
                let next_to = self
                    .fixed_targets
                    .obj_poss
                    .iter()
                    .any(|b| (a.0 - b.0).abs() + (a.1 - b.1).abs() == 1);
                if next_to {
                    Status::Success
                } else {
                    Status::Continue
                }
            }
        }
    }
}

impl SeqNode {
    fn verify(&mut self, action: Action, v: &Verify<'_>) -> Status {
        match self.kind {
            SeqKind::Before => ordered(
                &mut self.a,
                &mut self.a_done,
                &mut self.b,
                &mut self.b_done,
                self.strict,
                action,
                v,
            ),
            SeqKind::After => ordered(
                &mut self.b,
                &mut self.b_done,
                &mut self.a,
                &mut self.a_done,
                self.strict,
                action,
                v,
            ),
            SeqKind::And => {
                if self.a_done != Status::Success {
                    self.a_done = self.a.verify(action, v);
                }
                if self.b_done != Status::Success {
                    self.b_done = self.b.verify(action, v);
                }
                // Python's done-mode failure check compares `action is actions.done`, which
                // is false for an int action: And never fails.
                if self.a_done == Status::Success && self.b_done == Status::Success {
                    Status::Success
                } else {
                    Status::Continue
                }
            }
        }
    }
}

/// `BeforeInstr.verify` with `first` = a (AfterInstr: with `first` = b).
fn ordered(
    first: &mut Instr,
    first_done: &mut Status,
    second: &mut Instr,
    second_done: &mut Status,
    strict: bool,
    action: Action,
    v: &Verify<'_>,
) -> Status {
    if *first_done == Status::Success {
        *second_done = second.verify(action, v);
        return match *second_done {
            Status::Failure => Status::Failure,
            Status::Success => Status::Success,
            Status::Continue => Status::Continue,
        };
    }
    *first_done = first.verify(action, v);
    match *first_done {
        Status::Failure => return Status::Failure,
        // Python recurses: the second part is asked about the same action at once.
        Status::Success => {
            return ordered(first, first_done, second, second_done, strict, action, v);
        }
        Status::Continue => {}
    }
    if strict && second.verify(action, v) == Status::Success {
        return Status::Failure;
    }
    Status::Continue
}

/// Parses a BabyAI mission into an instruction tree: `CLAUSES [", then" CLAUSES | "after
/// you" CLAUSES]`, where `CLAUSES` is `CLAUSE ["and" CLAUSE]` (the grammar `rand_instr`
/// generates). The split follows BabyAI's tokenizer, so punctuation is ignored.
pub fn parse_mission(text: &str) -> Result<Instr, EnvError> {
    let words = super::vocab::split_words(text);
    let w: Vec<&str> = words.iter().map(String::as_str).collect();
    let bad = |e: ParseError| EnvError::InvalidMission {
        mission: text.to_owned(),
        reason: e.describe(&w),
    };
    let seq_at = w
        .iter()
        .position(|x| *x == "then")
        .map(|i| (i, i + 1, SeqKind::Before))
        .or_else(|| {
            w.windows(2)
                .position(|p| p == ["after", "you"])
                .map(|i| (i, i + 2, SeqKind::After))
        });
    if let Some((end_a, start_b, kind)) = seq_at {
        let a = parse_and(&w[..end_a]).map_err(bad)?;
        let b = parse_and(&w[start_b..])
            .map_err(|e| e.shift(start_b))
            .map_err(bad)?;
        return Ok(Instr::seq(kind, a, b));
    }
    parse_and(&w).map_err(bad)
}

fn parse_and(w: &[&str]) -> Result<Instr, ParseError> {
    // "and" never occurs inside a clause of BabyAI's grammar.
    if let Some(i) = w.iter().position(|x| *x == "and") {
        let a = Instruction::parse_words(&w[..i])?;
        let b = Instruction::parse_words(&w[i + 1..]).map_err(|e| e.shift(i + 1))?;
        return Ok(Instr::seq(SeqKind::And, a.into(), b.into()));
    }
    Instruction::parse_words(w).map(Instr::from)
}

#[cfg(test)]
mod tests;
