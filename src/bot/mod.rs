//! BabyAI's bot (`minigrid/utils/baby_ai_bot.py`, `BabyAIBot`, minigrid 3.2.0), ported
//! action for action: a planner with privileged state that solves the BabyAI levels.
//!
//! It keeps a stack of subgoals (Close, Open, Drop, Pickup, GoNextTo, Explore) made from the
//! instruction, a mask of every cell the agent has seen, and plans on that mask with
//! breadth-first searches. [`Bot::replan`] is told the action actually taken (its own or
//! someone else's) and revises the plan around it, so the same bot is an agent on every
//! level, the expert beside any agent's episode and the source of demonstrations.
//!
//! Kept as minigrid has them (docs/bot.md lists them): the searches' tie-breaking, the pairing
//! of a description's objects with positions that are refreshed only after a drop, the
//! undo of other actions (a turn is undone by going next to the cell that was in front), the
//! give-up on an opened box, and every assertion of the Python code — where minigrid's bot
//! raises (or replans more than [`MAX_REPLANS`] times in one step, the bound the shared
//! fixture script uses), this one gives up for the rest of the episode and says why.
//! Deterministic: no randomness anywhere.
//!
//! Beyond BabyAI it plans the MiniGrid environments rewarded for picking up one object
//! (KeyCorridor, UnlockPickup, BlockedUnlockPickup, ObstructedMaze: [`plans`]), given BabyAI's
//! `pick up the <color> <kind>` of that object; on ObstructedMaze's presets whose keys are in
//! boxes it gives up when it needs a key (it never opens a box, as minigrid's bot never does).

mod dump;
mod search;
mod subgoal;

use serde::{Deserialize, Serialize};

use crate::env::instr::Targets;
use crate::env::minigrid::Rules;
use crate::env::{Action, DIR_TO_VEC, ObjDesc, ObjectId, ObjectKind, Observation, Pos, World};

pub use dump::verify_bot;
use search::Planner;
pub use subgoal::{Datum, Reason, Subgoal, SubgoalKind};

/// Subgoal replans allowed within one step; past it minigrid's bot is looping
/// (`gen_minigrid_fixtures.py`'s `MAX_REPLANS`).
pub const MAX_REPLANS: u32 = 2000;

/// Why the bot gave up; from then on it suggests nothing for the rest of the episode.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(rename_all = "snake_case")]
pub enum GiveUp {
    /// A box was opened (`DisappearedBoxError`: what it held may be gone).
    #[error("a box was opened; the bot cannot tell what it held")]
    BoxOpened,
    /// More than [`MAX_REPLANS`] subgoal replans within one step.
    #[error("more than {MAX_REPLANS} subgoal replans in one step (the plan loops)")]
    Looping,
    /// Explore found no unseen cell and no closed door.
    #[error("nothing left to explore")]
    NothingToExplore,
    /// One of minigrid's own assertions (or a Python error) would have raised.
    #[error("the plan broke: {0}")]
    Broken(String),
}

/// What the bot remembers of the state it last planned in (`_remember_current_state`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
struct Memory {
    agent_pos: Pos,
    carrying: Option<ObjectId>,
    /// `fwd_door_was_open`: set when a door was last in front; Python's attribute does not
    /// exist before that.
    fwd_door_was_open: Option<bool>,
    fwd_was_box: bool,
}

/// minigrid's `BabyAIBot` for one episode (serialisable, so that a training run's
/// demonstrations resume exactly).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Bot {
    planner: Planner,
    stack: Vec<Subgoal>,
    memory: Memory,
    gave_up: Option<GiveUp>,
    replans: u32,
}

/// The agent's pose as each subgoal sees it (`update_agent_attributes`): identical for every
/// subgoal during one replan, since the world does not change while the bot plans.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pose {
    pub pos: Pos,
    pub dir_vec: Pos,
    pub right_vec: Pos,
    pub fwd_pos: Pos,
}

impl Pose {
    fn of(world: &World) -> Self {
        let dir_vec = DIR_TO_VEC[usize::from(world.agent_dir & 3)];
        let pos = world.agent_pos;
        Self {
            pos,
            dir_vec,
            right_vec: (-dir_vec.1, dir_vec.0),
            fwd_pos: (pos.0 + dir_vec.0, pos.1 + dir_vec.1),
        }
    }
}

impl Bot {
    /// A bot for the episode that starts in `world` (a freshly reset level): its stack is
    /// the instruction's subgoals (`_process_instr`). On a MiniGrid environment rewarded for
    /// picking up one object ([`Rules::Pickup`]) they are those of BabyAI's
    /// `pick up the <color> <kind>` of that object, its description matching that object
    /// alone.
    pub fn new(world: &World) -> Self {
        let mut stack = Vec::new();
        let mut gave_up = None;
        if let Some(Rules::Pickup { target }) = &world.rules {
            match pickup_target(world, *target) {
                Some(datum) => push_pickup(datum, &mut stack),
                None => {
                    gave_up = Some(GiveUp::Broken(
                        "the object to pick up is not on the grid".to_owned(),
                    ));
                }
            }
        } else {
            let mut clause = 0;
            process_instr(&world.instr, &mut clause, &mut stack);
        }
        Self {
            planner: Planner::new(world.grid.width() as i32, world.grid.height() as i32),
            stack,
            memory: Memory::default(),
            gave_up,
            replans: 0,
        }
    }

    /// `replan(action_taken)`: the action the bot suggests in `world`, told the action taken
    /// since its last call (`None` on the first call). `None` once it has given up.
    pub fn replan(&mut self, world: &World, taken: Option<Action>) -> Option<Action> {
        self.replan_seeing(world, &world.observe(), taken)
    }

    /// [`Self::replan`] with the observation of `world` the caller already made (what the
    /// agent sees: its visible cells are what the bot marks as seen).
    pub fn replan_seeing(
        &mut self,
        world: &World,
        obs: &Observation,
        taken: Option<Action>,
    ) -> Option<Action> {
        if self.gave_up.is_some() {
            return None;
        }
        match self.try_replan(world, obs, taken) {
            Ok(a) => Some(a),
            Err(e) => {
                self.gave_up = Some(e);
                self.stack.clear();
                None
            }
        }
    }

    /// The subgoal stack after the last replan, bottom first (empty once given up).
    pub fn stack(&self) -> &[Subgoal] {
        &self.stack
    }

    /// Why the bot gave up, if it did.
    pub fn gave_up(&self) -> Option<&GiveUp> {
        self.gave_up.as_ref()
    }

    /// The stack as one line, top first, e.g. `GoNextTo (3, 5) → Pickup → Drop`.
    pub fn plan_text(&self, world: &World) -> String {
        if let Some(g) = &self.gave_up {
            return format!("gave up: {g}");
        }
        if self.stack.is_empty() {
            return "done".to_string();
        }
        self.stack
            .iter()
            .rev()
            .map(|s| s.describe(world))
            .collect::<Vec<_>>()
            .join(" → ")
    }

    fn try_replan(
        &mut self,
        world: &World,
        obs: &Observation,
        taken: Option<Action>,
    ) -> Result<Action, GiveUp> {
        self.process_obs(world, obs);
        if taken == Some(Action::Toggle) && self.memory.fwd_was_box {
            return Err(GiveUp::BoxOpened);
        }
        let pose = Pose::of(world);
        if let Some(top) = self.stack.last().cloned() {
            self.after_action(world, pose, &top, taken)?;
        }
        while self.stack.last().is_some_and(Subgoal::is_exploratory) {
            self.stack.pop();
        }
        self.replans = 0;
        let mut suggested = None;
        while let Some(top) = self.stack.last().cloned() {
            self.replans += 1;
            if self.replans > MAX_REPLANS {
                return Err(GiveUp::Looping);
            }
            if let Some(a) = self.before_action(world, pose, &top)? {
                suggested = Some(a);
                break;
            }
        }
        // The loop ends with an action, or with an empty stack: the mission is done.
        self.remember(world, pose);
        Ok(suggested.unwrap_or(Action::Done))
    }

    /// `_process_obs`: marks every cell of the current view the agent can see. (On the
    /// first step of the PutNext "Carrying" levels the observation shows the carried object
    /// on the floor, as minigrid's reset saw it; objects do not block the view, so the cells
    /// seen are the same.)
    fn process_obs(&mut self, world: &World, obs: &Observation) {
        for vx in 0..crate::env::VIEW_SIZE {
            for vy in 0..crate::env::VIEW_SIZE {
                if !obs.visible((vx, vy)) {
                    continue;
                }
                let p = crate::env::world_from_view(world.agent_pos, world.agent_dir, (vx, vy));
                if let Some(i) = self.planner.index(p) {
                    self.planner.vis[i] = true;
                }
            }
        }
    }

    fn remember(&mut self, world: &World, pose: Pose) {
        let fwd = world.grid.get(pose.fwd_pos);
        self.memory.agent_pos = world.agent_pos;
        self.memory.carrying = world.carrying.map(|c| c.id);
        if let Some(d) = fwd.filter(|o| o.kind == ObjectKind::Door) {
            self.memory.fwd_door_was_open = Some(d.state == crate::env::DoorState::Open);
        }
        self.memory.fwd_was_box = fwd.is_some_and(|o| o.kind == ObjectKind::Box);
    }

    /// The objects and positions a [`Datum`] description stands for now, with its type.
    fn desc_targets<'a>(
        world: &'a World,
        datum: &'a Datum,
    ) -> Option<(Option<ObjectKind>, &'a Targets)> {
        match datum {
            Datum::Clause { clause, fixed } => {
                let node = *world.instr.clauses().get(*clause)?;
                if *fixed {
                    Some((node.instr.fixed?.kind, &node.fixed_targets))
                } else {
                    Some((node.instr.desc.kind, &node.targets))
                }
            }
            Datum::Own { desc, targets } => Some((desc.kind, targets)),
            Datum::Pos(_) | Datum::Door(_) => None,
        }
    }

    /// `ObjDesc("key", color).find_matching_objs(env)`: a description the bot makes itself,
    /// with what it matches now (it is never refreshed afterwards).
    fn key_desc(world: &World, color: crate::env::Color) -> Datum {
        let desc = ObjDesc {
            kind: Some(ObjectKind::Key),
            color: Some(color),
            loc: None,
        };
        let targets = Targets::find(
            desc,
            &world.grid,
            world.rooms,
            world.agent_pos,
            world.agent_dir,
        );
        Datum::Own { desc, targets }
    }
}

/// The expert's plan on MiniGrid's own environments it does not plan (every one but those
/// [`plans`] takes), where BabyAI's bot has no instruction to plan.
pub const NO_EXPERT: &str = "none: BabyAI's bot plans BabyAI instructions only";

/// Whether the bot plans `world`: every BabyAI level, and the MiniGrid environments rewarded
/// for picking up one object ([`Rules::Pickup`]: KeyCorridor, UnlockPickup,
/// BlockedUnlockPickup, ObstructedMaze), whose mission is a BabyAI pickup instruction. The
/// other MiniGrid rules (a goal to reach, Fetch's any pickup, PutNear's drop, …) have none.
pub fn plans(world: &World) -> bool {
    matches!(world.rules, None | Some(Rules::Pickup { .. }))
}

/// The bot beside an episode: told every action taken (its own suggestions or anyone
/// else's, as minigrid's bot is in `gen_minigrid_fixtures.py`), it gives at each step the
/// action it would take and its plan.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Expert {
    bot: Bot,
    taken: Option<Action>,
}

impl Expert {
    /// The expert of the episode that starts in `world`.
    pub fn new(world: &World) -> Self {
        Self {
            bot: Bot::new(world),
            taken: None,
        }
    }

    /// The action it would take in `world`, the state before the next action, whose
    /// observation is `obs`; `None` once it has given up, and always on a MiniGrid
    /// environment it does not plan ([`plans`]).
    pub fn advise(&mut self, world: &World, obs: &Observation) -> Option<Action> {
        if !plans(world) {
            // No BabyAI instruction to plan: no expert.
            return None;
        }
        self.bot.replan_seeing(world, obs, self.taken.take())
    }

    /// Its plan after the last [`Self::advise`], top first, or why it gave up ([`NO_EXPERT`]
    /// where it does not plan).
    pub fn plan(&self, world: &World) -> String {
        if !plans(world) {
            return NO_EXPERT.to_owned();
        }
        self.bot.plan_text(world)
    }

    /// Tells it the action actually taken after [`Self::advise`].
    pub fn told(&mut self, action: Action) {
        self.taken = Some(action);
    }
}

/// What the bot labels of a level, run alone from the given level seeds: the steps it advised
/// (an imitation run's labelled frames), the steps the episodes would have lasted (past a
/// give-up, to the horizon: frames a run spends without a label) and the episodes it gave up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LabelShare {
    /// Steps the bot advised.
    pub labelled: u64,
    /// Steps in all: advised, plus each give-up's remaining steps to the horizon.
    pub steps: u64,
    /// Episodes where it gave up before the end.
    pub gave_up: u64,
    /// Episodes probed.
    pub episodes: u64,
}

impl LabelShare {
    /// The labelled share of the steps (0 when there were none).
    pub fn share(&self) -> f64 {
        self.labelled as f64 / self.steps.max(1) as f64
    }
}

/// [`LabelShare`] of `level` on `seeds`: the bot acts until the episode ends or it gives up
/// (KeyInBox's key hidden in a box, as ObstructedMaze's "h" presets hide theirs: it explores
/// a few steps, then has no plan); nothing is labelled where it does not plan ([`plans`]).
pub fn label_share(
    level: &crate::env::LevelConfig,
    seeds: impl IntoIterator<Item = u64>,
) -> Result<LabelShare, crate::env::EnvError> {
    let mut out = LabelShare::default();
    for seed in seeds {
        let mut world = level.generate(seed)?;
        let mut expert = Expert::new(&world);
        out.episodes += 1;
        while !world.ended() {
            let Some(action) = expert.advise(&world, &world.observe()) else {
                out.gave_up += 1;
                out.steps += u64::from(world.max_steps.saturating_sub(world.step_count));
                break;
            };
            out.labelled += 1;
            out.steps += 1;
            let outcome = world.step(action)?;
            expert.told(action);
            if outcome.terminated || outcome.truncated {
                break;
            }
        }
    }
    Ok(out)
}

/// The bot alone from `world` to the end of the episode: how many actions it took and
/// whether it succeeded (`None` where it gave up before the end).
pub fn solo_length(mut world: World) -> Option<(usize, bool)> {
    let mut expert = Expert::new(&world);
    let mut steps = 0;
    while !world.ended() {
        let action = expert.advise(&world, &world.observe())?;
        let outcome = world.step(action).ok()?;
        expert.told(action);
        steps += 1;
        if outcome.terminated || outcome.truncated {
            return Some((steps, outcome.reward > 0.0));
        }
    }
    Some((steps, false))
}

/// The bot's cost to finish from the world `before` once `action` is taken: 0 where the action
/// succeeds, the bot's own steps from there where it then succeeds alone, `None` (no finish)
/// where the episode ends without success or the bot cannot finish.
fn cost_after(before: &World, action: Action) -> Option<usize> {
    let mut world = before.clone();
    let outcome = world.step(action).ok()?;
    if outcome.terminated || outcome.truncated {
        return (outcome.reward > 0.0).then_some(0);
    }
    solo_length(world).and_then(|(n, ok)| ok.then_some(n))
}

/// Whether taking `taken` where the bot advised `advised` (in the world `before` the action)
/// costs anything: the bot alone needs more steps to succeed after `taken` than after
/// `advised`, or can succeed only after `advised`. A tie — turning left or right to face
/// what is behind, either way round an obstacle — costs nothing, so it is not where an
/// episode went wrong; nor is a step from which the bot could not finish either way.
pub fn divergence_matters(before: &World, taken: Action, advised: Action) -> bool {
    if taken == advised {
        return false;
    }
    match (cost_after(before, taken), cost_after(before, advised)) {
        (Some(t), Some(a)) => t > a,
        (None, Some(_)) => true,
        (_, None) => false,
    }
}

/// `_process_instr`: a clause's subgoals, pushed so that the first to do is on top; a
/// Before / And does its first part first, an After its second.
fn process_instr(instr: &crate::env::Instr, clause: &mut usize, stack: &mut Vec<Subgoal>) {
    use crate::env::{Instr, SeqKind, TaskKind};
    match instr {
        Instr::Action(n) => {
            let me = *clause;
            *clause += 1;
            let desc = Datum::Clause {
                clause: me,
                fixed: false,
            };
            match n.instr.task {
                TaskKind::GoTo => stack.push(Subgoal::go_next_to(desc, None)),
                TaskKind::Open => {
                    stack.push(Subgoal::new(SubgoalKind::Open, None, None));
                    stack.push(Subgoal::go_next_to(desc, Some(Reason::Open)));
                }
                TaskKind::Pickup => push_pickup(desc, stack),
                TaskKind::PutNext => {
                    let fixed = Datum::Clause {
                        clause: me,
                        fixed: true,
                    };
                    stack.push(Subgoal::new(SubgoalKind::Drop, None, None));
                    stack.push(Subgoal::go_next_to(fixed, Some(Reason::PutNext)));
                    stack.push(Subgoal::new(SubgoalKind::Pickup, None, None));
                    stack.push(Subgoal::go_next_to(desc, None));
                }
            }
        }
        Instr::Seq(s) => {
            // Clauses are numbered in reading order (a before b) whatever the push order.
            let a_first = *clause;
            let mut count = 0;
            count_clauses(&s.a, &mut count);
            let mut b_first = a_first + count;
            let mut a_at = a_first;
            match s.kind {
                SeqKind::Before | SeqKind::And => {
                    process_instr(&s.b, &mut b_first, stack);
                    process_instr(&s.a, &mut a_at, stack);
                }
                SeqKind::After => {
                    process_instr(&s.a, &mut a_at, stack);
                    process_instr(&s.b, &mut b_first, stack);
                }
            }
            *clause = b_first;
        }
    }
}

/// A Pickup clause's subgoals (`PickupInstr` in `_process_instr`): go next to the object,
/// pick it up, drop it (the drop minigrid's bot plans after every pickup).
fn push_pickup(desc: Datum, stack: &mut Vec<Subgoal>) {
    stack.push(Subgoal::new(SubgoalKind::Drop, None, None));
    stack.push(Subgoal::new(SubgoalKind::Pickup, None, None));
    stack.push(Subgoal::go_next_to(desc, None));
}

/// The description of `pick up the <color> <kind>` for MiniGrid's pickup target `target`,
/// matching that object alone: MiniGrid rewards picking up that very object (by identity),
/// so another of its kind and colour — KeyCorridor's door key when the class is asked for a
/// key of the door's colour — must not be taken for it. `None` where it is not on the grid.
/// The target leaves its cell only when it is picked up (by the bot, even as a blocker, or by
/// anyone), which ends the episode with success, so its one position never goes stale.
fn pickup_target(world: &World, target: ObjectId) -> Option<Datum> {
    let pos = world.grid.find_id(target)?;
    let obj = world.grid.get(pos)?;
    let desc = ObjDesc {
        kind: Some(obj.kind),
        color: Some(obj.color),
        loc: None,
    };
    let targets = Targets {
        obj_set: vec![target],
        obj_poss: vec![pos],
        pose: None,
    };
    Some(Datum::Own { desc, targets })
}

fn count_clauses(instr: &crate::env::Instr, n: &mut usize) {
    match instr {
        crate::env::Instr::Action(_) => *n += 1,
        crate::env::Instr::Seq(s) => {
            count_clauses(&s.a, n);
            count_clauses(&s.b, n);
        }
    }
}

#[cfg(test)]
mod tests;
