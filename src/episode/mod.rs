//! Episode traces: the one hand-off from `env` + `policy` to every consumer (metrics,
//! recordings, the debugger). A trace is never recomputed elsewhere.

mod json;
mod replay;
mod request;

pub use replay::replay_actions;
pub use request::EpisodeRequest;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::Serialize;

use crate::bot::Expert;
use crate::env::level::LevelConfig;
use crate::env::view::Observation;
use crate::env::vocab;
use crate::env::world::{Action, World};
use crate::policy::{self, Acting, AttentionTrace, Checkpoint, Memory, Net, PolicyError, Step};

/// How actions are chosen from the policy's probabilities.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ActionMode {
    /// The most probable action (ties go to the lowest index).
    Greedy,
    /// Sampled from the probabilities with an RNG seeded by the episode seed.
    Sampled,
}

impl ActionMode {
    /// `greedy` or `sampled`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Greedy => "greedy",
            Self::Sampled => "sampled",
        }
    }
}

/// One step: what the agent saw and attended to, what it did, and what happened.
#[derive(Clone, Debug)]
pub struct StepRecord {
    /// Step index, 0-based: the state before action `t`.
    pub t: usize,
    /// The world before the action.
    pub world: World,
    /// The observation the policy saw.
    pub obs: Observation,
    /// The attention trace (attention variant only).
    pub attention: Option<AttentionTrace>,
    /// Action probabilities.
    pub probs: [f32; Action::COUNT],
    /// Critic value.
    pub value: f32,
    /// The action taken.
    pub action: Action,
    /// Reward the action earned.
    pub reward: f64,
    /// The action ended the task (success or failure).
    pub terminated: bool,
    /// The action reached `max_steps`.
    pub truncated: bool,
    /// What minigrid's bot would do here, told every action taken before
    /// ([`crate::bot::Expert`]); `None` where it has given up.
    pub expert_action: Option<Action>,
    /// The bot's plan at this step, top first (`GoNextTo (3, 5) → Pickup → Drop`), or why it
    /// gave up.
    pub expert_plan: String,
    /// Faithfulness measures of this step, when asked for
    /// ([`crate::metrics::faithfulness::annotate`]).
    pub faithfulness: Option<StepFaithfulness>,
}

/// What `replay --faithfulness` measures at a step (docs/faithfulness.md).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StepFaithfulness {
    /// Δ of each view cell when it alone is replaced by empty floor, agent-up like the maps
    /// (0 for cells not replaced).
    pub occlusion: crate::policy::ViewMap,
    /// Spearman ρ of `M` and Δ over the 48 cells other than the agent's; `None` when either
    /// is constant, and for the baseline.
    pub rank_correlation: Option<f64>,
    /// One-step interventions on `M` by name: the total-variation distance of the action
    /// distributions and whether the most probable action changed.
    pub interventions: std::collections::BTreeMap<String, InterventionOutcome>,
}

/// The effect of one intervention on one step's action distribution.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct InterventionOutcome {
    /// Total-variation distance to the unperturbed distribution.
    pub tv: f64,
    /// The most probable action changed.
    pub flip: bool,
}

/// A whole episode.
#[derive(Clone, Debug)]
pub struct EpisodeTrace {
    /// The checkpoint that acted (its path or name).
    pub checkpoint: String,
    /// Its variant.
    pub variant: policy::Variant,
    /// The level.
    pub level: LevelConfig,
    /// The level seed.
    pub seed: u64,
    /// Mission text (as the policy read it).
    pub mission: String,
    /// Mission tokens.
    pub tokens: Vec<u32>,
    /// The mission's ids as the policy received them, where they are not `tokens` (an
    /// imported graph's own vocabulary): what to feed the graph to get the same numbers.
    pub input_token_ids: Option<Vec<i64>>,
    /// The name the model gives itself (an imported graph's `groundscope.name`), shown with
    /// `checkpoint`.
    pub model_name: Option<String>,
    /// Greedy or sampled.
    pub mode: ActionMode,
    /// How many actions the policy scores ([`Acting::n_actions`]): MiniGrid's first
    /// `n_actions`, 7 or 3 (left, right, forward); each step's `probs` is 0 past them, and
    /// displays show only these ([`Self::action_probs`]). Read again after every step, for a
    /// policy that learns its width from its first answer (a Python callable).
    pub n_actions: usize,
    /// The steps.
    pub steps: Vec<StepRecord>,
    /// The world after the last action.
    pub final_world: World,
}

impl EpisodeTrace {
    /// Whether the episode ended in success (a positive reward).
    pub fn success(&self) -> bool {
        self.steps.last().is_some_and(|s| s.reward > 0.0)
    }

    /// The episode's return (BabyAI rewards only the last step).
    pub fn total_reward(&self) -> f64 {
        self.steps.iter().map(|s| s.reward).sum()
    }

    /// The mission's words.
    pub fn words(&self) -> Vec<&'static str> {
        vocab::words(&self.tokens)
    }

    /// The probabilities of the actions the policy scores at `step` ([`Self::n_actions`] of
    /// them, at least one): what every display lists.
    pub fn action_probs<'a>(&self, step: &'a StepRecord) -> &'a [f32] {
        &step.probs[..self.n_actions.clamp(1, Action::COUNT)]
    }
}

/// Chooses an action from probabilities.
pub fn choose(probs: &[f32], mode: ActionMode, rng: &mut Pcg64Mcg) -> Action {
    let idx = match mode {
        ActionMode::Greedy => greedy_index(probs),
        ActionMode::Sampled => crate::policy::sample_index(probs, rng.random()),
    };
    Action::from_index(idx).unwrap_or(Action::Done)
}

/// The greedy action's index: the most probable, the first of equals.
pub fn greedy_index(probs: &[f32]) -> usize {
    probs
        .iter()
        .enumerate()
        .fold((0, f32::NEG_INFINITY), |best, (i, &p)| {
            if p > best.1 { (i, p) } else { best }
        })
        .0
}

/// What to run: the level, seed, optional mission override and action mode.
#[derive(Clone, Debug)]
pub struct EpisodeSpec {
    /// The level.
    pub level: LevelConfig,
    /// The level seed.
    pub seed: u64,
    /// A mission that replaces the generated one (its words must be in the vocabulary and
    /// name an object of the level).
    pub mission: Option<String>,
    /// Greedy or sampled.
    pub mode: ActionMode,
}

/// Refuses a step whose action probabilities, value or attention maps are not finite (a
/// model that computes NaN), naming the step, as training refuses a diverged update.
fn check_finite(
    probs: &[f32; Action::COUNT],
    value: f32,
    attention: Option<&crate::policy::AttentionTrace>,
    t: usize,
    spec: &EpisodeSpec,
) -> Result<(), PolicyError> {
    let what = if probs.iter().any(|p| !p.is_finite()) {
        "action probabilities"
    } else if !value.is_finite() {
        "value"
    } else if attention.is_some_and(|a| {
        a.combined.iter().flatten().any(|x| !x.is_finite())
            || a.words.iter().any(|w| {
                !w.entropy.is_finite()
                    || !w.weight.is_finite()
                    || w.map.iter().flatten().any(|x| !x.is_finite())
            })
    }) {
        "attention maps"
    } else {
        return Ok(());
    };
    Err(PolicyError::Input(format!(
        "the model computed non-finite {what} at step {t} of {} seed {}: it cannot be run",
        spec.level, spec.seed
    )))
}

/// A step's refusal (an imported graph's NaN or negative map) with the step named, as
/// [`check_finite`] names it.
fn at_step(e: PolicyError, t: usize, spec: &EpisodeSpec) -> PolicyError {
    match e {
        PolicyError::Input(m) => PolicyError::Input(format!(
            "{m}, at step {t} of {} seed {}",
            spec.level, spec.seed
        )),
        other => other,
    }
}

/// The world an episode spec starts from.
pub fn initial_world(spec: &EpisodeSpec) -> Result<World, PolicyError> {
    let mut world = spec.level.generate(spec.seed)?;
    if let Some(text) = &spec.mission {
        world.set_instruction(crate::env::parse_mission(text)?)?;
    }
    vocab::tokenize_on_level(&world.mission, || {
        format!("{} seed {}", spec.level, spec.seed)
    })?;
    Ok(world)
}

/// Runs `net` from `world` to the end of the episode. The same inputs give the same trace.
pub fn run_from<P: Acting + ?Sized>(
    net: &P,
    checkpoint: &str,
    spec: &EpisodeSpec,
    world: World,
) -> Result<EpisodeTrace, PolicyError> {
    run_fresh(net, checkpoint, spec, world, Hooks::default())
}

/// [`run_from`], showing `on_step` the episode so far after each step (the debugger shows
/// the first steps while the rest are computed): its last step is the new one and its
/// `final_world` the world after it. `on_step` returning `false` stops the episode there,
/// with the steps taken so far. Stopped or not, the steps are those [`run_from`] takes.
pub fn run_from_observed<P: Acting + ?Sized>(
    net: &P,
    checkpoint: &str,
    spec: &EpisodeSpec,
    world: World,
    on_step: &mut dyn FnMut(&EpisodeTrace) -> bool,
) -> Result<EpisodeTrace, PolicyError> {
    let hooks = Hooks {
        intervene: None,
        on_step: Some(on_step),
    };
    run_fresh(net, checkpoint, spec, world, hooks)
}

/// What a running episode calls besides the policy: an intervention before each step and an
/// observer after it.
#[derive(Default)]
struct Hooks<'a> {
    intervene: Option<Intervene<'a>>,
    on_step: Option<&'a mut dyn FnMut(&EpisodeTrace) -> bool>,
}

/// An episode from `world` with a fresh memory and sampling RNG.
fn run_fresh<P: Acting + ?Sized>(
    net: &P,
    checkpoint: &str,
    spec: &EpisodeSpec,
    world: World,
    hooks: Hooks<'_>,
) -> Result<EpisodeTrace, PolicyError> {
    let tokens = crate::policy::acting::world_tokens(net, &world, || {
        format!("{} seed {}", spec.level, spec.seed)
    })?;
    let memory = net.zero_memory()?;
    let expert = Expert::new(&world);
    run_loop(
        net,
        checkpoint,
        spec,
        world,
        tokens,
        memory,
        episode_rng(spec.seed),
        (Vec::new(), expert),
        hooks,
    )
}

/// Chooses an intervention on the attention for the step about to be taken, from the world,
/// its observation, the mission's tokens and the memory before the step.
pub type Intervene<'a> = &'a dyn Fn(
    &World,
    &Observation,
    &[u32],
    &Memory,
) -> Result<Option<policy::Intervention>, PolicyError>;

/// [`run_from`] with an intervention on the attention at every step (closed-loop probes;
/// see `metrics::faithfulness`). The trace shows the changed weights and `M`.
pub fn run_from_with<P: Acting + ?Sized>(
    net: &P,
    checkpoint: &str,
    spec: &EpisodeSpec,
    world: World,
    intervene: Intervene<'_>,
) -> Result<EpisodeTrace, PolicyError> {
    let hooks = Hooks {
        intervene: Some(intervene),
        on_step: None,
    };
    run_fresh(net, checkpoint, spec, world, hooks)
}

/// The action-sampling RNG of an episode.
pub fn episode_rng(seed: u64) -> Pcg64Mcg {
    Pcg64Mcg::seed_from_u64(seed ^ 0x9E37_79B9_7F4A_7C15)
}

/// Re-runs an episode from an edited state at step `k`: the first `k` steps of `trace` are
/// kept, their observations are fed again to rebuild the agent's memory (and its sampling RNG
/// is advanced past them), then the policy runs from `world` — what the agent would have done
/// had the world looked like that at step `k`.
pub fn rerun_from<P: Acting + ?Sized>(
    net: &P,
    trace: &EpisodeTrace,
    k: usize,
    world: World,
) -> Result<EpisodeTrace, PolicyError> {
    let k = k.min(trace.steps.len());
    let prefix = trace.steps[..k].to_vec();
    let mut memory = net.zero_memory()?;
    let mut rng = episode_rng(trace.seed);
    let mission = net.prepare(&trace.tokens)?;
    let mut expert = Expert::new(prefix.first().map_or(&world, |s| &s.world));
    for s in &prefix {
        expert.advise(&s.world, &s.obs);
        expert.told(s.action);
        if net.reads_world() {
            choose(&s.probs, trace.mode, &mut rng);
            continue;
        }
        let tokens = trace.tokens.as_slice();
        let out = net.act_step(&Step {
            prepared: mission.as_ref(),
            ..Step::one(&s.obs, &s.world.agent_dir, &tokens, &memory)
        })?;
        memory = out.memory;
        choose(&s.probs, trace.mode, &mut rng);
    }
    let spec = EpisodeSpec {
        level: trace.level,
        seed: trace.seed,
        mission: None,
        mode: trace.mode,
    };
    let tokens = vocab::tokenize(&world.mission)?;
    run_loop(
        net,
        &trace.checkpoint,
        &spec,
        world,
        tokens,
        memory,
        rng,
        (prefix, expert),
        Hooks::default(),
    )
}

#[expect(
    clippy::too_many_arguments,
    reason = "the whole state of a running episode"
)]
fn run_loop<P: Acting + ?Sized>(
    net: &P,
    checkpoint: &str,
    spec: &EpisodeSpec,
    world: World,
    tokens: Vec<u32>,
    mut memory: Memory,
    mut rng: Pcg64Mcg,
    (steps, mut expert): (Vec<StepRecord>, Expert),
    mut hooks: Hooks<'_>,
) -> Result<EpisodeTrace, PolicyError> {
    let mission = net.prepare(&tokens)?;
    // The trace is built as the episode goes, its `final_world` the world now, so that an
    // observer sees the episode so far.
    let mut trace = EpisodeTrace {
        checkpoint: checkpoint.to_owned(),
        variant: net.variant(),
        level: spec.level,
        seed: spec.seed,
        mission: world.mission.clone(),
        input_token_ids: net.input_token_ids(&tokens),
        model_name: net.model_name(),
        tokens,
        mode: spec.mode,
        n_actions: net.n_actions().clamp(1, Action::COUNT),
        steps,
        final_world: world,
    };
    while !trace.final_world.ended() {
        let world = &mut trace.final_world;
        let t = trace.steps.len();
        let obs = world.observe();
        let expert_action = expert.advise(world, &obs);
        let expert_plan = expert.plan(world);
        let out = if net.reads_world() {
            net.act_from_expert(&[expert_action])?
        } else {
            let iv = match hooks.intervene {
                Some(f) => f(world, &obs, &trace.tokens, &memory)?,
                None => None,
            };
            let tokens = trace.tokens.as_slice();
            net.act_step(&Step {
                prepared: mission.as_ref(),
                traces: true,
                intervention: iv.as_ref(),
                ..Step::one(&obs, &world.agent_dir, &tokens, &memory)
            })
            .map_err(|e| at_step(e, t, spec))?
        };
        // Read again once the policy has answered: a Python callable learns its width (3 or
        // 7 logits) and whether it gives maps from its first answer, after the trace began.
        trace.n_actions = net.n_actions().clamp(1, Action::COUNT);
        trace.variant = net.variant();
        memory = out.memory;
        let probs_v = out.probs.into_iter().next().unwrap_or_default();
        let mut probs = [0.0; Action::COUNT];
        for (p, v) in probs.iter_mut().zip(&probs_v) {
            *p = *v;
        }
        let value = out.values.first().copied().unwrap_or(0.0);
        let attention = out.traces.and_then(|t| t.into_iter().next());
        check_finite(&probs, value, attention.as_ref(), t, spec)?;
        // Only the actions it scores: a sampled draw past their sum (rounding) would
        // otherwise fall on the zero-padded last action, `done`.
        let action = choose(&probs[..trace.n_actions], spec.mode, &mut rng);
        expert.told(action);
        let before = world.clone();
        let outcome = world.step(action)?;
        trace.steps.push(StepRecord {
            t,
            world: before,
            obs,
            attention,
            probs,
            value,
            action,
            reward: outcome.reward,
            terminated: outcome.terminated,
            truncated: outcome.truncated,
            expert_action,
            expert_plan,
            faithfulness: None,
        });
        if let Some(on_step) = hooks.on_step.as_mut()
            && !on_step(&trace)
        {
            break;
        }
    }
    Ok(trace)
}

/// Runs a checkpoint on an episode spec.
pub fn run_episode(
    ckpt: &Checkpoint,
    name: &str,
    spec: &EpisodeSpec,
) -> Result<EpisodeTrace, PolicyError> {
    let net = Net::new(ckpt.meta.model, ckpt.params.detached())?;
    run_from(&net, name, spec, initial_world(spec)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::LevelConfig;
    use crate::policy::{AttentionTrace, WordAttention};

    #[test]
    fn a_non_finite_step_is_refused_naming_the_step() {
        let spec = EpisodeSpec {
            level: LevelConfig::default(),
            seed: 9,
            mission: None,
            mode: ActionMode::Greedy,
        };
        let probs = [1.0 / 7.0; Action::COUNT];
        assert!(check_finite(&probs, 0.5, None, 3, &spec).is_ok());
        let mut nan = probs;
        nan[2] = f32::NAN;
        let err = check_finite(&nan, 0.5, None, 3, &spec)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("action probabilities at step 3") && err.contains("seed 9"),
            "{err}"
        );
        let err = check_finite(&probs, f32::INFINITY, None, 4, &spec)
            .unwrap_err()
            .to_string();
        assert!(err.contains("value at step 4"), "{err}");
        let mut map = [[0.0; 7]; 7];
        map[1][1] = f32::NAN;
        let trace = AttentionTrace {
            words: vec![WordAttention {
                word: "ball".into(),
                token: 7,
                map,
                entropy: 1.0,
                weight: 1.0,
            }],
            combined: [[0.0; 7]; 7],
        };
        let err = check_finite(&probs, 0.0, Some(&trace), 5, &spec)
            .unwrap_err()
            .to_string();
        assert!(err.contains("attention maps at step 5"), "{err}");
    }
}
