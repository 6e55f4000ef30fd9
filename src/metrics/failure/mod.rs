//! Failure classes: why an evaluated episode failed. The one place the classes are defined.
//!
//! The targets are the objects the clauses the verifier is waiting on matched
//! ([`crate::metrics::grounding::pending_targets`]: on the paper's level, the one clause's).
//! Every failed episode gets exactly one class. On MiniGrid's own environments (a world with
//! MiniGrid's step rules) its MiniGrid class comes first, where one holds ([`minigrid`],
//! [`FailureClass::MINIGRID`] in order): how the episode ended — `stepped_into_lava`,
//! `hit_obstacle`, `picked_wrong_object`, `doors_out_of_order`, `dropped_far_from_target`,
//! `wrong_end_object` — else the first link of its level's chain it never got past —
//! `box_never_opened`, `key_never_picked_up`, `locked_door_never_opened`,
//! `rooms_never_entered`. Otherwise (and on every BabyAI level) the order is:
//! 1. [`FailureClass::LockedDoorNoKey`]: at the last step every target lay in rooms the agent
//!    never entered, every door of those rooms stayed closed, and one of them was locked with
//!    a key of its colour never carried.
//! 2. [`FailureClass::DoorNeverOpened`]: as 1, the doors closed but none locked without its
//!    key carried — or (rule 8) the verifier waited on an Open clause whose doors never opened.
//! 3. [`FailureClass::TargetRoomNeverEntered`]: the targets lay in rooms never entered, and
//!    some door of those rooms had been open.
//! 4. [`FailureClass::TargetNeverVisible`]: at no step was a target object in the agent's
//!    7×7 view. "Visible" uses the observation the policy saw: a view cell other than the
//!    agent's own whose encoding is not "unseen" (so occluded cells do not count) and whose
//!    world cell holds an object of the verifier's target set.
//! 5. [`FailureClass::Grounding`]: the target was visible but the combined map `M` missed it.
//!    At each step with a visible target, `M` is "on the target" when its largest cell
//!    ([`m_points_at`]) is a visible target's cell or the cell one step in front of one (the
//!    two cells `acc_cmb` accepts); `M` missed the target when it was on it at fewer than half
//!    of those steps. Needs `M`: never assigned to a baseline.
//! 6. [`FailureClass::WrongOrder`]: the agent picked up or opened an object of a clause the
//!    sequence had not reached (Before's second part, After's first).
//! 7. [`FailureClass::WrongNeighbour`]: the agent put PutNext's object down beside other
//!    keys/balls/boxes, none of them one the clause named.
//! 8. `door_never_opened` for an Open clause (rule 2).
//! 9. [`FailureClass::WrongObject`]: the episode terminated without success on a `done` or
//!    `pickup` while the cell in front held a key/ball/box outside every clause's objects, or
//!    while the agent carried one.
//! 10. [`FailureClass::TurningInPlace`]: the episode was truncated at the step limit and its
//!     last [`TURN_WINDOW`] actions were all `left`/`right` turns.
//! 11. [`FailureClass::Other`]: everything else (wandering to the limit, `done` in front of
//!     nothing, ...).
//!
//! Besides its class, every failed episode gets a *behaviour* ([`Diagnosis::behaviour`]):
//! what the agent was doing, whichever rule decided the class — the first of
//! [`FailureClass::WrongOrder`], [`FailureClass::WrongNeighbour`], [`FailureClass::WrongObject`],
//! [`FailureClass::TurningInPlace`] and [`FailureClass::BlockedForward`] (truncated with the
//! agent in the same cell over its last [`TURN_WINDOW`] steps, at least one a `forward` into a
//! cell it cannot enter), [`FailureClass::RepeatedNoOp`] (truncated, its last [`TURN_WINDOW`]
//! actions all a `pickup`, `drop` or `toggle` that could change nothing) and
//! [`FailureClass::Cycling`] (truncated, its last [`CYCLE_WINDOW`] steps through at most
//! [`CYCLE_STATES`] poses, not only turning) whose condition holds, or none. An agent in a maze that turns until
//! the step limit is `door_never_opened` by the order above (the targets lay behind closed
//! doors) and `turning_in_place` by behaviour: the class says what it never reached, the
//! behaviour what it did instead. The class order is kept so that the paper's level's counts
//! stay comparable across reports.
//!
//! Rules 1–3 and 6–8 ([`mechanics`]) need doors, rooms, sequences or PutNext: on the paper's
//! level they never fire. Without `M` (a baseline checkpoint) rule 5 is skipped: a baseline
//! failure with the target visible is classed by the later rules only, so its counts never
//! contain `grounding`.
//!
//! Why the largest cell and the majority of visible steps: a threshold on `M`'s value (the
//! report's `acc_cmb` at τ = α / n) depends on how many words share the weight — with a word
//! temperature (`--word-temperature`) `M` mixes every mission word's map, its peak on the
//! target holding a third of the mass, under τ = 0.5 at every step — whereas where `M`
//! points does not; the cell in front is accepted because trained maps often settle one cell
//! forward of their object (`acc_bs`). One step alone is noisy — the last step a target is
//! visible is typically the step it leaves the view's edge while the agent turns — while the
//! majority of visible steps says whether `M` tracked the target while the agent could act on
//! it. Ties count as "on the target", so `grounding` is claimed only when `M` missed more
//! often than it hit.
//!
//! The counterfactual verdict re-runs a failed episode's level seed with every non-target
//! key/ball/box removed from the initial world ([`without_distractors`], [`counterfactual`]):
//! does the agent succeed once nothing can distract it?

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::error::MetricsError;
use super::faithfulness::measures::argmax;
use super::faithfulness::step::index_cell;
use super::grounding::pending_targets;
use crate::env::EnvError;
use crate::env::edit::{Edit, apply};
use crate::env::view::{Observation, ViewCell};
use crate::env::world::{Action, World};
use crate::episode::{EpisodeSpec, EpisodeTrace, initial_world, run_from};
use crate::policy::{PolicyError, ViewMap};

/// How many final actions of a truncated episode must all be turns for
/// [`FailureClass::TurningInPlace`]: two full rotations, longer than any useful scan.
pub const TURN_WINDOW: usize = 8;

/// How many final steps of a truncated episode [`FailureClass::Cycling`] looks at: long
/// enough that a path revisiting at most [`CYCLE_STATES`] poses cannot be a search.
pub const CYCLE_WINDOW: usize = 32;

/// The most distinct poses (cell and direction) the last [`CYCLE_WINDOW`] steps may visit for
/// [`FailureClass::Cycling`]: a loop around one 2×2 block of cells takes eight.
pub const CYCLE_STATES: usize = 8;

/// What the key/ball/box in front of (or carried by) the agent was, relative to the targets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Relation {
    /// No key, ball or box.
    Nothing,
    /// One of the verifier's targets.
    Target,
    /// A key, ball or box outside the target set.
    NonTarget,
}

/// How the episode ended (its last step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ending {
    /// The last action earned a positive reward.
    pub success: bool,
    /// The last action ended the task.
    pub terminated: bool,
    /// The last action reached the step limit.
    pub truncated: bool,
    /// The last action.
    pub action: Action,
    /// The cell in front before the last action.
    pub front: Relation,
    /// The carried object before the last action.
    pub carried: Relation,
}

/// One step as the classifier reads it (a [`crate::episode::StepRecord`] or a sweep step).
#[derive(Clone, Copy, Debug)]
pub struct StepFacts<'a> {
    /// The world before the action.
    pub world: &'a World,
    /// The observation the policy saw.
    pub obs: &'a Observation,
    /// The combined map `M` (`None` without attention).
    pub combined: Option<&'a ViewMap>,
    /// The action taken.
    pub action: Action,
    /// Reward the action earned.
    pub reward: f64,
    /// The action ended the task.
    pub terminated: bool,
    /// The action reached the step limit.
    pub truncated: bool,
}

/// What an episode showed, accumulated step by step; [`Evidence::diagnose`] classifies it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Evidence {
    /// Steps seen.
    pub steps: u32,
    /// Steps with a target visible.
    pub target_visible_steps: u32,
    /// Of those, the steps where `M` was available.
    pub m_steps: u32,
    /// Of those, the steps where `M` was on a visible target ([`m_points_at`]).
    pub m_on_target_steps: u32,
    /// The last [`TURN_WINDOW`] steps, oldest first.
    pub recent: Vec<RecentStep>,
    /// The agent's pose (cell, direction) before each of the last [`CYCLE_WINDOW`] steps,
    /// oldest first.
    pub poses: std::collections::VecDeque<((i32, i32), u8)>,
    /// The last step, once the episode ended.
    pub ending: Option<Ending>,
    /// Rooms, doors, keys, sequences and PutNext ([`mechanics`]).
    pub mechanics: Mechanics,
    /// MiniGrid's own endings and chains ([`minigrid`]; empty on BabyAI's levels).
    pub minigrid: MiniGridEvidence,
}

/// One of an episode's last steps, as the ending rules read it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecentStep {
    /// The action taken.
    pub action: Action,
    /// The agent's cell before it.
    pub pos: (i32, i32),
    /// It was a `forward` into a cell the agent cannot enter.
    pub blocked: bool,
    /// It was a `pickup`, `drop` or `toggle` that could change nothing ([`no_op_press`]).
    pub no_op: bool,
}

/// Whether `action` in `world` is a `pickup`, `drop` or `toggle` that can change nothing:
/// pickup with the hands full or nothing to lift in front, drop with empty hands or the cell
/// in front taken, toggle in front of neither a door nor a box, or of a locked door without
/// its key in hand.
pub fn no_op_press(world: &World, action: Action) -> bool {
    use crate::env::object::{DoorState, ObjectKind};
    let front = world.grid.get(world.front_pos());
    match action {
        Action::Pickup => world.carrying.is_some() || !front.is_some_and(|o| o.kind.can_pickup()),
        Action::Drop => world.carrying.is_none() || front.is_some(),
        Action::Toggle => match front {
            Some(o) if o.kind == ObjectKind::Door && o.state == DoorState::Locked => !world
                .carrying
                .is_some_and(|c| c.kind == ObjectKind::Key && c.color == o.color),
            Some(o) => !matches!(o.kind, ObjectKind::Door | ObjectKind::Box),
            None => true,
        },
        _ => false,
    }
}

/// The class of one failed episode and the counts it rests on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Diagnosis {
    /// The failure class.
    pub class: FailureClass,
    /// Steps with a target in view.
    pub target_visible_steps: u32,
    /// Of those, steps with `M` on a target (`None` when `M` was never evaluated: a
    /// baseline, or no visible target).
    pub m_on_target_steps: Option<u32>,
    /// What the agent was doing ([`FailureClass::BEHAVIOURS`]; `None`: none of them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub behaviour: Option<FailureClass>,
    /// The step where the episode was lost, where its mechanics show one: the act a MiniGrid
    /// class names ([`minigrid`]: the step into lava, the collision, the wrong pickup, the
    /// blue door, the drop, the step onto the wrong end; for a chain class the first chance
    /// passed up, else the last step its object was in view), else the early door of
    /// `wrong_order`, the drop of `wrong_neighbour` ([`decisive_step`] falls back on the first
    /// divergence from the bot that matters, then the last step).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lost_at: Option<u32>,
}

/// The step to open a failed episode at: where its mechanics show it was lost
/// ([`Diagnosis::lost_at`]), else the first step at which it left the bot's plan at a cost
/// ([`crate::bot::divergence_matters`]), else its last step (`length − 1`).
pub fn decisive_step(lost_at: Option<u32>, first_divergence: Option<u32>, length: u32) -> u32 {
    lost_at
        .or(first_divergence)
        .unwrap_or_else(|| length.saturating_sub(1))
}

/// The first step of `trace` at which the agent left the bot's advice at a cost
/// ([`crate::bot::divergence_matters`]): what `eval` reports as an episode's `diverge`,
/// found from a recorded trace.
pub fn first_divergence(trace: &crate::episode::EpisodeTrace) -> Option<u32> {
    trace
        .steps
        .iter()
        .find(|s| {
            s.expert_action
                .is_some_and(|a| crate::bot::divergence_matters(&s.world, s.action, a))
        })
        .map(|s| u32::try_from(s.t).unwrap_or(u32::MAX))
}

/// The objects of every clause (both of PutNext's descriptions): what is not a distractor.
pub fn all_targets(world: &World) -> Vec<crate::env::object::ObjectId> {
    world
        .instr
        .clauses()
        .iter()
        .flat_map(|n| n.targets.obj_set.iter().chain(&n.fixed_targets.obj_set))
        .copied()
        .collect()
}

/// Whether `m`'s largest cell (the first in row order on ties) is one of `targets` or the
/// cell one step in front of one (view row `y − 1`): the pointing game of
/// [`super::faithfulness::measures::localisation`] on the two cells `acc_cmb` accepts.
pub fn m_points_at(m: &ViewMap, targets: &[ViewCell]) -> bool {
    let flat: Vec<f64> = m.iter().flatten().map(|&v| f64::from(v)).collect();
    let (x, y) = index_cell(argmax(&flat));
    targets
        .iter()
        .any(|&(tx, ty)| tx == x && (ty == y || ty == y + 1))
}

/// Where a key/ball/box stands relative to `world`'s targets.
pub fn relation(world: &World, obj: Option<crate::env::object::WorldObj>) -> Relation {
    match obj {
        Some(o) if o.kind.can_pickup() => {
            if all_targets(world).contains(&o.id) {
                Relation::Target
            } else {
                Relation::NonTarget
            }
        }
        _ => Relation::Nothing,
    }
}

impl Evidence {
    /// Adds one step.
    pub fn push(&mut self, step: &StepFacts<'_>) {
        self.push_seeing(step, &pending_targets(step.world, step.obs));
    }

    /// [`Evidence::push`] with the step's visible targets already found
    /// (`pending_targets(step.world, step.obs)`): the sweep finds them once per step for the
    /// classifier and the exploration [`super::exploration::Tracker`].
    pub fn push_seeing(&mut self, step: &StepFacts<'_>, cells: &[ViewCell]) {
        self.steps = self.steps.saturating_add(1);
        if !cells.is_empty() {
            self.target_visible_steps += 1;
            if let Some(m) = step.combined {
                self.m_steps += 1;
                if m_points_at(m, cells) {
                    self.m_on_target_steps += 1;
                }
            }
        }
        if self.recent.len() == TURN_WINDOW {
            self.recent.remove(0);
        }
        let w = step.world;
        self.recent.push(RecentStep {
            action: step.action,
            pos: w.agent_pos,
            blocked: step.action == Action::Forward
                && w.grid.get(w.front_pos()).is_some_and(|o| !o.can_overlap()),
            no_op: no_op_press(w, step.action),
        });
        if self.poses.len() == CYCLE_WINDOW {
            self.poses.pop_front();
        }
        self.poses.push_back((w.agent_pos, w.agent_dir));
        self.mechanics.push(step);
        self.minigrid.push(step);
        if step.terminated || step.truncated {
            self.ending = Some(Ending {
                success: step.reward > 0.0,
                terminated: step.terminated,
                truncated: step.truncated,
                action: step.action,
                front: relation(w, w.grid.get(w.front_pos())),
                carried: relation(w, w.carrying),
            });
        }
    }

    /// The evidence of a whole trace.
    pub fn from_trace(trace: &EpisodeTrace) -> Self {
        let mut e = Self::default();
        for s in &trace.steps {
            e.push(&StepFacts {
                world: &s.world,
                obs: &s.obs,
                combined: s.attention.as_ref().map(|a| &a.combined),
                action: s.action,
                reward: s.reward,
                terminated: s.terminated,
                truncated: s.truncated,
            });
        }
        e
    }

    /// Whether the last [`CYCLE_WINDOW`] steps went through at most [`CYCLE_STATES`] poses
    /// and more than one cell.
    fn cycles(&self) -> bool {
        if self.poses.len() < CYCLE_WINDOW {
            return false;
        }
        let poses: std::collections::BTreeSet<_> = self.poses.iter().collect();
        let cells: std::collections::BTreeSet<_> = self.poses.iter().map(|p| p.0).collect();
        poses.len() <= CYCLE_STATES && cells.len() > 1
    }

    /// The failure class, or `None` for a successful episode. An episode with no recorded
    /// ending (empty or unfinished) counts as failed: rules 3 and 4 need an ending, so it
    /// falls to rules 1, 2 or 5.
    pub fn diagnose(&self) -> Option<Diagnosis> {
        if self.ending.is_some_and(|e| e.success) {
            return None;
        }
        let with_m = self.m_steps > 0;
        let act = self.mechanics.act_class();
        let wrong_object = self.ending.is_some_and(|e| {
            e.terminated
                && matches!(e.action, Action::Done | Action::Pickup)
                && (e.front == Relation::NonTarget || e.carried == Relation::NonTarget)
        });
        let truncated = self.ending.is_some_and(|e| e.truncated);
        let full = self.recent.len() == TURN_WINDOW;
        let turning = truncated
            && full
            && self
                .recent
                .iter()
                .all(|r| matches!(r.action, Action::Left | Action::Right));
        let blocked = truncated
            && full
            && self.recent.iter().any(|r| r.blocked)
            && self.recent.iter().all(|r| r.pos == self.recent[0].pos);
        let minigrid = self.minigrid.class();
        let class = if let Some((c, _)) = minigrid {
            c
        } else if let Some(c) = self.mechanics.room_class() {
            c
        } else if self.target_visible_steps == 0 {
            FailureClass::TargetNeverVisible
        } else if with_m && 2 * self.m_on_target_steps < self.m_steps {
            FailureClass::Grounding
        } else if let Some(c) = act {
            c
        } else if wrong_object {
            FailureClass::WrongObject
        } else if turning {
            FailureClass::TurningInPlace
        } else {
            FailureClass::Other
        };
        let pressing = truncated && full && self.recent.iter().all(|r| r.no_op);
        let cycling = truncated && !turning && self.cycles();
        let behaviour = act
            .filter(|c| matches!(c, FailureClass::WrongOrder | FailureClass::WrongNeighbour))
            .or_else(|| wrong_object.then_some(FailureClass::WrongObject))
            .or_else(|| turning.then_some(FailureClass::TurningInPlace))
            .or_else(|| blocked.then_some(FailureClass::BlockedForward))
            .or_else(|| pressing.then_some(FailureClass::RepeatedNoOp))
            .or_else(|| cycling.then_some(FailureClass::Cycling));
        Some(Diagnosis {
            class,
            target_visible_steps: self.target_visible_steps,
            m_on_target_steps: with_m.then_some(self.m_on_target_steps),
            behaviour,
            lost_at: minigrid.and_then(|(_, t)| t).or_else(|| {
                self.mechanics.wrong_step.filter(|_| {
                    matches!(
                        behaviour,
                        Some(FailureClass::WrongOrder | FailureClass::WrongNeighbour)
                    )
                })
            }),
        })
    }
}

/// Counts of each class over `failures`: every class decidable for a model with or without
/// `M` is present (zero included); `grounding` is absent without `M` (not decidable, which
/// is not zero), and the classes of BabyAI's mechanics are absent on the paper's level
/// (`mechanics` false), where they cannot occur. The counts sum to the number of diagnoses given.
pub fn class_counts<'a>(
    failures: impl IntoIterator<Item = &'a Diagnosis>,
    with_m: bool,
    mechanics: bool,
) -> BTreeMap<FailureClass, u64> {
    let mut counts: BTreeMap<FailureClass, u64> = FailureClass::ALL
        .iter()
        .filter(|c| c.decidable(with_m) && (mechanics || !FailureClass::MECHANICS.contains(c)))
        .map(|&c| (c, 0))
        .collect();
    for d in failures {
        *counts.entry(d.class).or_default() += 1;
    }
    counts
}

/// Counts of each behaviour over `failures` ([`Diagnosis::behaviour`]), `None` for the
/// failures that showed none; only behaviours seen are present.
pub fn behaviour_counts<'a>(
    failures: impl IntoIterator<Item = &'a Diagnosis>,
) -> BTreeMap<Option<FailureClass>, u64> {
    let mut counts = BTreeMap::new();
    for d in failures {
        *counts.entry(d.behaviour).or_default() += 1;
    }
    counts
}

/// The counterfactual verdict: the same level seed, mission and action mode, with every
/// non-target key/ball/box removed from the initial world.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Counterfactual {
    /// Objects removed.
    pub distractors_removed: u32,
    /// Whether the re-run succeeded.
    pub success: bool,
    /// Its return.
    pub reward: f64,
    /// Its length.
    pub length: u32,
}

/// `world` with every key, ball and box that is not a target removed (through
/// [`crate::env::edit`], so the result is a consistent world with the same targets), and the
/// number removed.
pub fn without_distractors(world: &World) -> Result<(World, u32), EnvError> {
    let targets = &all_targets(world);
    let distractors: Vec<_> = world
        .grid
        .objects()
        .filter(|(_, o)| o.kind.can_pickup() && !targets.contains(&o.id))
        .map(|(p, _)| p)
        .collect();
    let mut edited = world.clone();
    for &p in &distractors {
        edited = apply(&edited, &Edit::Remove(p))?;
    }
    Ok((edited, u32::try_from(distractors.len()).unwrap_or(u32::MAX)))
}

/// Re-runs `spec` on `net` from its initial world without distractors. Deterministic: the
/// same checkpoint and spec give the same verdict (greedy, or sampled with the episode's own
/// seeded RNG, as [`run_from`] does).
pub fn counterfactual<P: crate::policy::Acting + ?Sized>(
    net: &P,
    checkpoint: &str,
    spec: &EpisodeSpec,
) -> Result<Counterfactual, MetricsError> {
    let world = initial_world(spec)?;
    let (world, removed) = without_distractors(&world).map_err(PolicyError::from)?;
    let trace = run_from(net, checkpoint, spec, world)?;
    Ok(Counterfactual {
        distractors_removed: removed,
        success: trace.success(),
        reward: trace.total_reward(),
        length: u32::try_from(trace.steps.len()).unwrap_or(u32::MAX),
    })
}

mod class;
pub mod mechanics;
pub mod minigrid;

pub use class::FailureClass;

pub use mechanics::Mechanics;
pub use minigrid::{MiniGridEvidence, classes_of};

#[cfg(test)]
mod tests;
