//! One episode: the unperturbed rollout with every step analysed ([`super::step`]), whole
//! episodes re-run with an intervention at every step (closed loop), and counterfactual
//! worlds edited at the start.

use std::collections::BTreeMap;

use candle_core::{Device, Tensor};
use rand::Rng as _;
use rand::SeedableRng as _;
use rand_pcg::Pcg64Mcg;

use super::measures::{argmax, flat};
use super::step::{StepInput, StepResult, analyse, cell_index, steered};
use crate::env::grid::Pos;
use crate::env::level::{LevelConfig, all_reachable};
use crate::env::mission::TaskKind;
use crate::env::object::{Color, ObjectKind, WorldObj};
use crate::env::roles::pending_clauses;
use crate::env::view::Observation;
use crate::env::vocab;
use crate::env::world::{Action, World};
use crate::episode::{ActionMode, choose, episode_rng};
use crate::metrics::failure::{Relation, relation};
use crate::metrics::grounding::{pending_targets, related_objects};
use crate::policy::obs::N_CELLS;
use crate::policy::{ActOutput, Acting, Intervention, Memory, PolicyError, Step};

/// Interventions applied at every step of a closed-loop re-run, in report order: the first
/// five change `M` (models that take interventions), the last two the observation the policy
/// sees (any model: the closed loop of a model without maps).
pub const CLOSED_LOOP: [&str; 7] = [
    "none",
    "uniform",
    "steered",
    "color_word_zero",
    "object_word_zero",
    "occlude_salient",
    "occlude_random",
];

/// The closed loops that change the input rather than `M`.
pub const INPUT_LOOPS: [&str; 2] = ["occlude_salient", "occlude_random"];

/// Counterfactual edits of the initial world, in report order.
pub const COUNTERFACTUALS: [&str; 5] = [
    "recolor_target",
    "move_target",
    "add_twin",
    "mission_color_to_distractor",
    "swap_putnext",
];

/// Which parts to compute.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[expect(
    clippy::struct_excessive_bools,
    reason = "one switch per part of the report"
)]
pub struct Parts {
    /// Occlusion, deletion/insertion, one-step interventions, localisation (per step).
    pub steps: bool,
    /// Closed-loop re-runs (a model that takes interventions on `M`).
    pub closed_loop: bool,
    /// Counterfactual worlds.
    pub counterfactuals: bool,
    /// The model takes interventions on `M` ([`crate::policy::Acting::takes_interventions`]).
    pub interventions: bool,
}

/// What a rollout did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rollout {
    /// The episode succeeded.
    pub success: bool,
    /// The agent picked up, or declared done at, an object the mission does not name.
    pub distractor: bool,
    /// Steps with a target in view.
    pub target_visible_steps: u32,
    /// Of those, steps where argmax `M` lies on a target.
    pub tracking_steps: u32,
}

/// A counterfactual's outcome: the edited episode, or why the edit was impossible.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Counterfactual {
    /// The edited world's episode.
    Ran(Rollout),
    /// The edit could not be made in this world.
    Skipped(String),
}

/// Everything measured on one episode.
#[derive(Clone, Debug, PartialEq)]
pub struct EpisodeResult {
    /// Evaluation seed.
    pub eval_seed: u64,
    /// Level seed.
    pub level_seed: u64,
    /// Mission.
    pub mission: String,
    /// The unperturbed episode.
    pub rollout: Rollout,
    /// Analysed steps (those with at least one object in view).
    pub steps: Vec<StepResult>,
    /// Closed-loop re-runs by intervention; missing where the mission has no such word.
    pub closed_loop: BTreeMap<&'static str, Rollout>,
    /// Counterfactuals by edit.
    pub counterfactuals: BTreeMap<&'static str, Counterfactual>,
}

/// How a closed-loop rollout changes the attention at each step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Loop {
    /// No change.
    None,
    /// `M` uniform.
    Uniform,
    /// `M` steered onto the nearest distractor ([`steered`]) where one is in view.
    Steered,
    /// The weight of the word at this position set to 0 and the rest renormalised.
    ZeroWord(usize),
    /// The object in view whose occlusion changes the action distribution most
    /// ([`super::step::occlusion_of`]) replaced by floor in what the policy sees.
    OccludeSalient,
    /// A random object in view replaced by floor in what the policy sees (the control of
    /// [`Loop::OccludeSalient`]).
    OccludeRandom,
}

/// The intervention `how` makes at a step, given the world, its observation, the mission's
/// tokens and the memory before the step (steering needs one unperturbed forward to know
/// `M`). The one definition used by closed-loop runs here and the debugger's probes.
pub fn intervention(
    agent: &(dyn Acting + Sync),
    how: Loop,
    world: &World,
    obs: &Observation,
    tokens: &[u32],
    memory: &Memory,
) -> Result<Option<Intervention>, PolicyError> {
    Ok(match how {
        Loop::None | Loop::OccludeSalient | Loop::OccludeRandom => None,
        Loop::Uniform => Some(Intervention::SetM(Tensor::full(
            1f32 / N_CELLS as f32,
            (1, N_CELLS),
            &Device::Cpu,
        )?)),
        Loop::ZeroWord(i) => {
            let mut f = vec![1f32; tokens.len()];
            if let Some(x) = f.get_mut(i) {
                *x = 0.0;
            }
            Some(Intervention::ScaleWeights(Tensor::from_vec(
                f,
                (1, tokens.len()),
                &Device::Cpu,
            )?))
        }
        Loop::Steered => {
            let base = agent.act_step(&Step {
                traces: true,
                ..Step::one(obs, &world.agent_dir, &tokens, memory)
            })?;
            let targets = pending_targets(world, obs);
            let objects = super::step::candidate_objects(obs, &targets);
            base.traces
                .as_ref()
                .and_then(|t| t.first())
                .and_then(|t| steered(&flat(&t.combined), &targets, &objects))
                .map(|s| {
                    let v: Vec<f32> = s.iter().map(|x| *x as f32).collect();
                    Tensor::from_vec(v, (1, N_CELLS), &Device::Cpu).map(Intervention::SetM)
                })
                .transpose()?
        }
    })
}

/// The position of the mission's colour word (`color`) or object word, if it has one.
pub fn word_position(world: &World, tokens: &[u32], color: bool) -> Option<usize> {
    let desc = world.desc();
    let word = if color {
        desc.color.map(Color::name)
    } else {
        desc.kind.map(ObjectKind::name)
    }?;
    let id = vocab::tokenize(word).ok()?.first().copied()?;
    tokens.iter().position(|t| *t == id)
}

/// Per-step state of the unperturbed rollout that the step analysis needs.
struct Visit {
    memory: Memory,
    words: Vec<crate::env::targets::WordTargets>,
    targets: Vec<crate::env::view::ViewCell>,
    obs: Observation,
    direction: u8,
    out: ActOutput,
    action: usize,
}

/// Whether the agent faces a door outside the targets of the clauses waited on, while those
/// targets are all doors.
fn at_distractor_door(world: &World) -> bool {
    use crate::env::object::ObjectKind;
    let ids = crate::env::tree::pending_target_ids(world);
    let doors = !ids.is_empty()
        && world
            .grid
            .objects()
            .filter(|(_, o)| ids.contains(&o.id))
            .all(|(_, o)| o.kind == ObjectKind::Door);
    doors
        && world
            .grid
            .get(world.front_pos())
            .is_some_and(|o| o.kind == ObjectKind::Door && !ids.contains(&o.id))
}

fn argmax_m(out: &ActOutput) -> Option<usize> {
    Some(argmax(&flat(&out.traces.as_ref()?.first()?.combined)))
}

/// Runs `world` to its end with `how` applied at every step; `visits` collects the steps for
/// the analysis when given (unperturbed runs only).
fn rollout(
    agent: &(dyn Acting + Sync),
    mut world: World,
    seed: u64,
    mode: ActionMode,
    how: &Loop,
    mut visits: Option<&mut Vec<Visit>>,
) -> Result<Rollout, PolicyError> {
    let tokens = vocab::tokenize(&world.mission)?;
    let mut memory = agent.zero_memory()?;
    let mut rng = episode_rng(seed);
    let mut r = Rollout::default();
    let attention = agent.variant() == crate::policy::Variant::Attention;
    // Its own stream, so that the random occlusions leave the action sampling as it was.
    let mut occlusion_rng = Pcg64Mcg::seed_from_u64(seed ^ 0x0CC1_0DED);
    while !world.ended() {
        let obs = world.observe();
        let direction = world.agent_dir;
        let seen = occluded(
            agent,
            *how,
            &obs,
            direction,
            &tokens,
            &memory,
            &mut occlusion_rng,
        )?;
        let iv = intervention(agent, *how, &world, &obs, &tokens, &memory)?;
        let mission = tokens.as_slice();
        let out = agent.act_step(&Step {
            traces: attention,
            intervention: iv.as_ref(),
            ..Step::one(&seen, &direction, &mission, &memory)
        })?;
        let probs = out.probs.first().cloned().unwrap_or_default();
        let action = choose(&probs, mode, &mut rng);
        let target_cells = pending_targets(&world, &obs);
        let targets: Vec<usize> = target_cells.iter().copied().map(cell_index).collect();
        if !targets.is_empty() {
            r.target_visible_steps += 1;
            if argmax_m(&out).is_some_and(|j| targets.contains(&j)) {
                r.tracking_steps += 1;
            }
        }
        if matches!(action, Action::Pickup | Action::Done)
            && relation(&world, world.grid.get(world.front_pos())) == Relation::NonTarget
        {
            r.distractor = true;
        }
        // Where the targets are doors, a distractor door is reached by facing it (GoTo's
        // success is facing its door) or toggling it.
        if at_distractor_door(&world) {
            r.distractor = true;
        }
        let next_memory = out.memory.clone();
        if let Some(v) = visits.as_deref_mut() {
            v.push(Visit {
                memory: memory.clone(),
                words: crate::env::targets::word_targets(&world, &obs, tokens.len()),
                targets: target_cells,
                obs,
                direction,
                out,
                action: action as usize,
            });
        }
        memory = next_memory;
        let outcome = world.step(action)?;
        if outcome.terminated && outcome.reward > 0.0 {
            r.success = true;
        }
    }
    Ok(r)
}

/// What the policy sees at this step under `how`: `obs` itself, or with one object in view
/// replaced by floor ([`Loop::OccludeSalient`], [`Loop::OccludeRandom`]).
fn occluded(
    agent: &(dyn Acting + Sync),
    how: Loop,
    obs: &Observation,
    direction: u8,
    tokens: &[u32],
    memory: &Memory,
    rng: &mut Pcg64Mcg,
) -> Result<Observation, PolicyError> {
    let objects = related_objects(obs, |_, _| true);
    let cell = match how {
        Loop::OccludeSalient if !objects.is_empty() => {
            let base = agent.act_step(&Step::one(obs, &direction, &tokens, memory))?;
            let probs = base.probs.first().cloned().unwrap_or_default();
            let delta = super::step::occlusion_of(agent, obs, direction, tokens, memory, &probs)?;
            objects
                .iter()
                .copied()
                .max_by(|a, b| delta[cell_index(*a)].total_cmp(&delta[cell_index(*b)]))
        }
        Loop::OccludeRandom if !objects.is_empty() => {
            Some(objects[rng.random_range(0..objects.len())])
        }
        _ => None,
    };
    let mut seen = *obs;
    if let Some((vx, vy)) = cell {
        seen.image[vx][vy] = super::step::EMPTY_FLOOR;
    }
    Ok(seen)
}

/// Free interior cells of `world` other than the agent's, in scan order.
fn free_cells(world: &World) -> Vec<Pos> {
    let (w, h) = (world.grid.width() as i32, world.grid.height() as i32);
    (1..h - 1)
        .flat_map(|y| (1..w - 1).map(move |x| (x, y)))
        .filter(|&p| world.grid.get(p).is_none() && p != world.agent_pos)
        .collect()
}

/// A world like `world` with `grid`, and clause `clause`'s description edited by `edit`,
/// targets resolved again; `Err` with the reason when it is not a valid start.
fn rebuilt(
    world: &World,
    grid: crate::env::grid::Grid,
    clause: usize,
    edit: impl FnOnce(&mut crate::env::mission::Instruction),
    next_id: u32,
) -> Result<World, String> {
    let mut instr = world.instr.clone();
    if let Some(n) = instr.clauses_mut().into_iter().nth(clause) {
        edit(&mut n.instr);
    }
    if !all_reachable(&grid, world.agent_pos) {
        return Err("the edit leaves an object unreachable".into());
    }
    World::with_tree(
        grid,
        world.rooms,
        world.agent_pos,
        world.agent_dir,
        world.carrying,
        instr,
        world.max_steps,
        world.done_actions,
        next_id,
    )
    .map_err(|e| e.to_string())
}

/// Colours no object of `kind` has in `world`.
fn unused_colors(world: &World, kind: ObjectKind) -> Vec<Color> {
    Color::ALL
        .into_iter()
        .filter(|c| {
            !world
                .grid
                .objects()
                .any(|(_, o)| o.kind == kind && o.color == *c)
        })
        .collect()
}

/// Applies counterfactual `name` to the initial `world`, on the clause the verifier waits on
/// first (the only clause on one-clause levels).
fn counterfactual(name: &str, world: &World, rng: &mut Pcg64Mcg) -> Result<World, String> {
    let clause = pending_clauses(&world.instr)
        .first()
        .copied()
        .ok_or("the verifier waits on no clause")?;
    let clauses = world.instr.clauses();
    let node = clauses.get(clause).ok_or("no such clause")?;
    if name == "swap_putnext" {
        // "put A next to B" becomes "put B next to A": the objects trade roles.
        if node.instr.task != TaskKind::PutNext {
            return Err("the clause is not PutNext".into());
        }
        return rebuilt(
            world,
            world.grid.clone(),
            clause,
            |i| {
                if let Some(f) = i.fixed.replace(i.desc) {
                    i.desc = f;
                }
            },
            world.next_id,
        );
    }
    let Some(&target_pos) = node.targets.obj_poss.first() else {
        return Err("the mission names no object".into());
    };
    let Some(target) = world.grid.get(target_pos) else {
        return Err("the target is not on the grid".into());
    };
    let desc = node.instr.desc;
    let door = target.kind == ObjectKind::Door;
    let pick = |v: &[Pos], rng: &mut Pcg64Mcg| -> Option<Pos> {
        (!v.is_empty()).then(|| v[rng.random_range(0..v.len())])
    };
    let set_color =
        |c: Option<Color>| move |i: &mut crate::env::mission::Instruction| i.desc.color = c;
    let mut grid = world.grid.clone();
    match name {
        "recolor_target" => {
            // The named object changes colour, and so does the mission where it names one.
            let colors = unused_colors(world, target.kind);
            let Some(&c) = colors.get(rng.random_range(0..colors.len().max(1))) else {
                return Err("every colour is taken by an object of the target's type".into());
            };
            grid.set(target_pos, Some(WorldObj { color: c, ..target }));
            rebuilt(
                world,
                grid,
                clause,
                set_color(desc.color.map(|_| c)),
                world.next_id,
            )
        }
        "move_target" => {
            if door {
                return Err("the target is a door, which stays in its wall".into());
            }
            let cells = free_cells(world);
            let Some(to) = pick(&cells, rng) else {
                return Err("no free cell".into());
            };
            grid.set(target_pos, None);
            grid.set(to, Some(target));
            rebuilt(world, grid, clause, |_| {}, world.next_id)
        }
        "add_twin" => {
            if desc.color.is_none() {
                return Err("the mission names no colour, so a twin would be a target".into());
            }
            if door {
                return Err("the target is a door; a twin door needs a wall".into());
            }
            let colors = unused_colors(world, target.kind);
            let Some(&c) = colors.first() else {
                return Err("every colour is taken by an object of the target's type".into());
            };
            let Some(at) = pick(&free_cells(world), rng) else {
                return Err("no free cell".into());
            };
            grid.set(at, Some(WorldObj::new(target.kind, c, world.next_id)));
            rebuilt(world, grid, clause, |_| {}, world.next_id + 1)
        }
        _ => {
            // "mission_color_to_distractor": name another object of the target's type.
            let others: Vec<Color> = world
                .grid
                .objects()
                .filter(|(_, o)| o.kind == target.kind && !desc.matches(o))
                .map(|(_, o)| o.color)
                .collect();
            let Some(&c) = others.first() else {
                return Err("no object of the target's type in another colour".into());
            };
            rebuilt(world, grid, clause, set_color(Some(c)), world.next_id)
        }
    }
}

/// Runs and analyses one episode of `level` at `level_seed`.
pub fn analyse_episode(
    agent: &(dyn Acting + Sync),
    level: &LevelConfig,
    eval_seed: u64,
    level_seed: u64,
    mode: ActionMode,
    parts: Parts,
) -> Result<EpisodeResult, PolicyError> {
    let world = level.generate(level_seed)?;
    let tokens = crate::policy::acting::world_tokens(agent, &world, || {
        format!("{level} seed {level_seed}")
    })?;
    let mut rng = Pcg64Mcg::seed_from_u64(level_seed ^ 0xFA17_4F11);
    let mut visits = Vec::new();
    let base = rollout(
        agent,
        world.clone(),
        level_seed,
        mode,
        &Loop::None,
        Some(&mut visits),
    )?;
    let mut steps = Vec::new();
    if parts.steps {
        for v in &visits {
            if super::step::candidate_objects(&v.obs, &v.targets).is_empty() {
                continue;
            }
            let probs = v.out.probs.first().cloned().unwrap_or_default();
            let input = StepInput {
                agent,
                direction: v.direction,
                tokens: &tokens,
                memory: &v.memory,
                obs: v.obs,
                words: v.words.clone(),
                targets: v.targets.clone(),
                probs: &probs,
                action: v.action,
                attention: v.out.traces.as_ref().and_then(|t| t.first()),
            };
            steps.push(analyse(&input, &mut rng)?);
        }
    }
    let mut closed_loop = BTreeMap::new();
    if parts.closed_loop {
        // A model that takes interventions on M gets those; any other the input occlusions.
        let names = CLOSED_LOOP
            .into_iter()
            .filter(|n| *n == "none" || INPUT_LOOPS.contains(n) != parts.interventions);
        for name in names {
            let how = match name {
                "none" => Some(Loop::None),
                "uniform" => Some(Loop::Uniform),
                "steered" => Some(Loop::Steered),
                "occlude_salient" => Some(Loop::OccludeSalient),
                "occlude_random" => Some(Loop::OccludeRandom),
                "color_word_zero" => word_position(&world, &tokens, true).map(Loop::ZeroWord),
                _ => word_position(&world, &tokens, false).map(Loop::ZeroWord),
            };
            if let Some(how) = how {
                let r = match how {
                    Loop::None => base,
                    _ => rollout(agent, world.clone(), level_seed, mode, &how, None)?,
                };
                closed_loop.insert(name, r);
            }
        }
    }
    let mut counterfactuals = BTreeMap::new();
    if parts.counterfactuals {
        for name in COUNTERFACTUALS {
            let knows = |w: &World| {
                vocab::tokenize(&w.mission)
                    .is_ok_and(|t| crate::policy::acting::unknown_word(agent, &t).is_none())
            };
            let outcome = match counterfactual(name, &world, &mut rng) {
                // An edited mission may name a word the model never learnt: not a valid probe.
                Ok(edited) if !knows(&edited) => Counterfactual::Skipped(
                    "the edited mission holds a word the model does not know".into(),
                ),
                Ok(edited) => Counterfactual::Ran(rollout(
                    agent,
                    edited,
                    level_seed,
                    mode,
                    &Loop::None,
                    None,
                )?),
                Err(reason) => Counterfactual::Skipped(reason),
            };
            counterfactuals.insert(name, outcome);
        }
    }
    Ok(EpisodeResult {
        eval_seed,
        level_seed,
        mission: world.mission.clone(),
        rollout: base,
        steps,
        closed_loop,
        counterfactuals,
    })
}

#[cfg(test)]
mod tests;
