//! Evaluation sweeps: every episode of a (checkpoint, size, objects) cell steps in lockstep
//! through one batched policy forward per step; per-episode summaries are aggregated as the
//! paper does (over evaluated steps in an episode, then over episodes, then mean ± std over
//! evaluation seeds).

use std::collections::BTreeMap;
use std::ops::Range;

use rand::SeedableRng as _;
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use super::error::MetricsError;
use super::exploration::{EpisodeExploration, Tracker};
use super::failure::{Diagnosis, Evidence, StepFacts};
use super::grounding::{Accuracies, WordKind, ground_step, pending_targets};
use crate::bot::Expert;
use crate::env::level::LevelConfig;
use crate::env::world::{Action, World};
use crate::episode::{ActionMode, choose};
use candle_core::{Device, Tensor};

use crate::policy::{Acting, Memory, PolicyError, Step};

mod stats;

pub use crate::env::seeds::{MAX_EVAL_SEEDS, eval_level_seed};
pub use stats::{
    ExpertStats, GroundingStats, MeanStd, Performance, expert_stats, grounding, performance,
};

/// What one evaluated episode produced.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeSummary {
    /// Evaluation seed.
    pub eval_seed: u64,
    /// Level seed (replays the episode).
    pub level_seed: u64,
    /// Mission text.
    pub mission: String,
    /// Whether it succeeded.
    pub success: bool,
    /// Its return.
    pub reward: f64,
    /// Steps taken.
    pub length: u32,
    /// Per word kind: mean accuracies over the evaluated steps, and their number.
    pub grounding: BTreeMap<WordKind, (Accuracies, u32)>,
    /// Why it failed (`None` for a success); see [`super::failure`].
    #[serde(default)]
    pub failure: Option<Diagnosis>,
    /// The actions taken, as indices (`episodes.csv`).
    #[serde(default)]
    pub actions: Vec<u8>,
    /// The episode beside minigrid's bot ([`crate::bot::Expert`]).
    #[serde(default)]
    pub expert: EpisodeExpert,
}

/// One episode beside minigrid's bot: the bot, told every action taken, gives the action it
/// would take at each step; and the bot alone from the same start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EpisodeExpert {
    /// Steps at which the bot had an action (it had not given up).
    pub steps: u32,
    /// Of those, the steps at which the agent took it.
    pub agreed: u32,
    /// The first step at which the agent did not take the bot's action and it cost something
    /// ([`crate::bot::divergence_matters`]: a left/right tie is passed over).
    pub first_divergence: Option<u32>,
    /// The bot's own length from the same start, where it succeeded alone.
    pub bot_length: Option<u32>,
}

impl EpisodeExpert {
    /// Share of the advised steps at which the agent took the bot's action (NaN: none).
    pub fn agreement(&self) -> f64 {
        if self.steps == 0 {
            f64::NAN
        } else {
            f64::from(self.agreed) / f64::from(self.steps)
        }
    }

    /// The bot's steps alone / the agent's steps, for a successful episode the bot also
    /// solves (NaN otherwise).
    pub fn path_efficiency(&self, success: bool, length: u32) -> f64 {
        match self.bot_length {
            Some(b) if success && length > 0 => f64::from(b) / f64::from(length),
            _ => f64::NAN,
        }
    }
}

/// One running episode of the lockstep batch.
struct Running {
    world: World,
    tokens: Vec<u32>,
    summary: EpisodeSummary,
    sums: BTreeMap<WordKind, (Accuracies, u32)>,
    evidence: Evidence,
    exploration: Tracker,
    rng: Pcg64Mcg,
    expert: Expert,
}

/// Runs `episodes` episodes of `level` for each evaluation seed in `seeds` in lockstep;
/// summaries come back in (seed, episode) order. `progress` is called with the number of
/// finished episodes.
pub fn evaluate_cell<P: Acting + ?Sized>(
    net: &P,
    level: &LevelConfig,
    seeds: Range<u64>,
    episodes: u64,
    alpha: f64,
    mode: ActionMode,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<EpisodeSummary>, MetricsError> {
    let opts = EvalOptions {
        alpha,
        mode,
        saliency: false,
    };
    let eps = evaluate_cell_explored(net, level, seeds, episodes, &opts, progress)?;
    Ok(eps.into_iter().map(|(s, _)| s).collect())
}

/// How a sweep evaluates its episodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvalOptions {
    /// The accuracies' `α` (threshold `τ = α / n`).
    pub alpha: f64,
    /// Greedy or sampled actions.
    pub mode: ActionMode,
    /// For a model without maps: compute the occlusion saliency
    /// ([`super::faithfulness::step::occlusion_of`]) at every step with a target in view and
    /// let it stand in for `M` in the failure classes (so `grounding` is decidable). Costs one
    /// forward of up to 48 perturbed views per such step; ignored for a model with maps.
    pub saliency: bool,
}

/// [`evaluate_cell`], each summary with its episode's exploration coverage
/// ([`super::exploration`]).
pub fn evaluate_cell_explored<P: Acting + ?Sized>(
    net: &P,
    level: &LevelConfig,
    seeds: Range<u64>,
    episodes: u64,
    opts: &EvalOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<(EpisodeSummary, EpisodeExploration)>, MetricsError> {
    let plan: Vec<(u64, u64)> = seeds
        .flat_map(|s| (0..episodes).map(move |e| (s, eval_level_seed(s, e))))
        .collect();
    evaluate_episodes_explored(net, level, &plan, opts, progress)
}

/// Runs one episode per `(eval_seed, level_seed)` of `plan` in lockstep; summaries come back
/// in plan order.
pub fn evaluate_episodes<P: Acting + ?Sized>(
    net: &P,
    level: &LevelConfig,
    plan: &[(u64, u64)],
    alpha: f64,
    mode: ActionMode,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<EpisodeSummary>, MetricsError> {
    let opts = EvalOptions {
        alpha,
        mode,
        saliency: false,
    };
    let eps = evaluate_episodes_explored(net, level, plan, &opts, progress)?;
    Ok(eps.into_iter().map(|(s, _)| s).collect())
}

/// [`evaluate_episodes`], each summary with its episode's exploration coverage. The
/// coverage is read from the same steps as the summary (the world before each action, the
/// observation and trace the policy produced), so it costs no extra forward pass.
pub fn evaluate_episodes_explored<P: Acting + ?Sized>(
    net: &P,
    level: &LevelConfig,
    plan: &[(u64, u64)],
    opts: &EvalOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<(EpisodeSummary, EpisodeExploration)>, MetricsError> {
    let EvalOptions {
        alpha,
        mode,
        saliency,
    } = *opts;
    let mut running = Vec::new();
    for &(s, level_seed) in plan {
        {
            // minigrid loops forever on a few seeds: no level exists there to evaluate.
            let world = match level.generate(level_seed) {
                Err(crate::env::EnvError::GenerationHangs { .. }) => continue,
                w => w.map_err(PolicyError::from)?,
            };
            let tokens = crate::policy::acting::world_tokens(net, &world, || {
                format!("{level} seed {level_seed}")
            })?;
            running.push(Running {
                summary: EpisodeSummary {
                    eval_seed: s,
                    level_seed,
                    mission: world.mission.clone(),
                    success: false,
                    reward: 0.0,
                    length: 0,
                    grounding: BTreeMap::new(),
                    failure: None,
                    actions: Vec::new(),
                    expert: EpisodeExpert {
                        bot_length: crate::bot::solo_length(world.clone())
                            .and_then(|(n, ok)| ok.then_some(n as u32)),
                        ..EpisodeExpert::default()
                    },
                },
                expert: Expert::new(&world),
                world,
                tokens,
                sums: BTreeMap::new(),
                evidence: Evidence::default(),
                exploration: Tracker::default(),
                rng: Pcg64Mcg::seed_from_u64(level_seed ^ 0x9E37_79B9_7F4A_7C15),
            });
        }
    }
    let total = running.len();
    let mut done: Vec<Option<(EpisodeSummary, EpisodeExploration)>> = vec![None; total];
    let mut active: Vec<usize> = (0..total).collect();
    let mut memory = net.zero_memory_batch(total)?;
    let want_traces = net.variant() == crate::policy::Variant::Attention;
    // Missions are fixed per episode: their GRU codes and queries are computed once.
    let all: Vec<&[u32]> = running.iter().map(|r| r.tokens.as_slice()).collect();
    let mission_all = net.prepare_batch(&all)?;
    let mut finished = 0u64;
    while !active.is_empty() {
        let obs: Vec<_> = active.iter().map(|&i| running[i].world.observe()).collect();
        // The bot beside each episode, told the last action taken: what it would do now.
        let advice: Vec<Option<Action>> = active
            .iter()
            .zip(&obs)
            .map(|(&i, o)| {
                let r = &mut running[i];
                r.expert.advise(&r.world, o)
            })
            .collect();
        let missions: Vec<&[u32]> = active
            .iter()
            .map(|&i| running[i].tokens.as_slice())
            .collect();
        let rows: Vec<u32> = active.iter().map(|&i| i as u32).collect();
        let rows = Tensor::from_vec(rows, active.len(), &Device::Cpu).map_err(PolicyError::from)?;
        let mission = mission_all.as_ref().map(|m| m.select(&rows)).transpose()?;
        let dirs: Vec<u8> = active.iter().map(|&i| running[i].world.agent_dir).collect();
        let out = if net.reads_world() {
            net.act_from_expert(&advice)?
        } else {
            net.act_step(&Step {
                obs: &obs,
                directions: &dirs,
                missions: &missions,
                rows: &active,
                prepared: mission.as_ref(),
                memory: &memory,
                traces: want_traces,
                intervention: None,
            })?
        };
        let mut keep = Vec::with_capacity(active.len());
        for (row, &i) in active.iter().enumerate() {
            let r = &mut running[i];
            let trace_row = out.traces.as_ref().and_then(|t| t.get(row));
            let mut combined = trace_row.map(|t| t.combined);
            // The step's visible targets, found once for the saliency, the failure classes
            // and the exploration tracker (`ground_step` finds its own for `M`).
            let targets = pending_targets(&r.world, &obs[row]);
            if saliency && trace_row.is_none() && !targets.is_empty() && !net.reads_world() {
                combined = Some(saliency_map(
                    net,
                    &obs[row],
                    dirs[row],
                    &r.tokens,
                    &memory,
                    row,
                    &out.probs[row],
                )?);
            }
            if let Some(traces) = &out.traces {
                let trace = &traces[row];
                let words: Vec<(&str, &crate::policy::ViewMap)> = trace
                    .words
                    .iter()
                    .map(|w| (w.word.as_str(), &w.map))
                    .collect();
                let g = ground_step(&r.world, &obs[row], &words, &trace.combined, alpha);
                for m in g.evaluated {
                    let e = r.sums.entry(m.kind).or_default();
                    e.0.add(&m.accuracies);
                    e.1 += 1;
                }
            }
            let action = choose(&out.probs[row], mode, &mut r.rng);
            r.summary.actions.push(action as u8);
            r.expert.told(action);
            if let Some(a) = advice[row] {
                let e = &mut r.summary.expert;
                if a == action {
                    e.agreed += 1;
                } else if e.first_divergence.is_none()
                    && crate::bot::divergence_matters(&r.world, action, a)
                {
                    e.first_divergence = Some(r.summary.length);
                }
                e.steps += 1;
            }
            // The failure classifier reads the world before the action, as a trace records it.
            let before = r.world.clone();
            let outcome = r.world.step(action).map_err(PolicyError::from)?;
            let facts = StepFacts {
                world: &before,
                obs: &obs[row],
                combined: combined.as_ref(),
                action,
                reward: outcome.reward,
                terminated: outcome.terminated,
                truncated: outcome.truncated,
            };
            r.evidence.push_seeing(&facts, &targets);
            r.exploration
                .push_seeing(&facts, trace_row.map(|t| t.words.as_slice()), &targets);
            r.summary.length += 1;
            r.summary.reward += outcome.reward;
            if outcome.terminated || outcome.truncated {
                r.summary.success = outcome.reward > 0.0;
                r.summary.grounding = r
                    .sums
                    .iter()
                    .map(|(k, (sum, n))| (*k, (sum.scaled(f64::from(*n)), *n)))
                    .collect();
                r.summary.failure = r.evidence.diagnose();
                let exploration = std::mem::take(&mut r.exploration).finish(r.world.agent_pos);
                done[i] = Some((r.summary.clone(), exploration));
                finished += 1;
            } else {
                keep.push(row);
            }
        }
        progress(finished);
        if keep.len() == active.len() {
            memory = out.memory;
        } else {
            let idx = candle_core::Tensor::from_vec(
                keep.iter().map(|&r| r as u32).collect::<Vec<u32>>(),
                keep.len(),
                &candle_core::Device::Cpu,
            )
            .map_err(PolicyError::from)?;
            memory = Memory {
                h: out
                    .memory
                    .h
                    .index_select(&idx, 0)
                    .map_err(PolicyError::from)?,
                c: out
                    .memory
                    .c
                    .index_select(&idx, 0)
                    .map_err(PolicyError::from)?,
            };
            active = keep.iter().map(|&r| active[r]).collect();
        }
    }
    Ok(done.into_iter().flatten().collect())
}

/// The occlusion saliency of row `row` as a map (agent-up), from that row's memory before
/// the step.
fn saliency_map<P: Acting + ?Sized>(
    net: &P,
    obs: &crate::env::view::Observation,
    direction: u8,
    tokens: &[u32],
    memory: &Memory,
    row: usize,
    probs: &[f32],
) -> Result<crate::policy::ViewMap, PolicyError> {
    let one = Memory {
        h: memory.h.narrow(0, row, 1)?,
        c: memory.c.narrow(0, row, 1)?,
    };
    let delta = super::faithfulness::step::occlusion_of(net, obs, direction, tokens, &one, probs)?;
    let delta: Vec<f32> = delta.iter().map(|x| *x as f32).collect();
    Ok(crate::policy::trace::to_map(&delta))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ep(seed: u64, success: bool, reward: f64, acc: Option<f64>) -> EpisodeSummary {
        let mut grounding = BTreeMap::new();
        if let Some(a) = acc {
            grounding.insert(
                WordKind::Object,
                (
                    Accuracies {
                        acc: a,
                        acc_ng: 1.0,
                        acc_bs: 0.0,
                        acc_cmb: a,
                        around: [0.0, 0.0, 0.0, 0.0, a, 0.0, 0.0, 0.0, 1.0 - a],
                        ..Accuracies::default()
                    },
                    2,
                ),
            );
        }
        EpisodeSummary {
            eval_seed: seed,
            level_seed: seed,
            mission: String::new(),
            success,
            reward,
            length: 4,
            grounding,
            failure: None,
            actions: Vec::new(),
            expert: crate::metrics::sweep::EpisodeExpert::default(),
        }
    }

    /// SynthS5R2's seed 1741 is one minigrid loops forever on: an evaluation skips it (no
    /// such level exists) and evaluates the seeds around it.
    #[test]
    fn seeds_minigrid_cannot_generate_are_skipped() {
        let id = crate::env::level::LevelId::parse("BabyAI-SynthS5R2-v0").unwrap();
        let level = LevelConfig::babyai(id, false);
        assert!(matches!(
            level.generate(1741),
            Err(crate::env::EnvError::GenerationHangs { .. })
        ));
        let plan = [(0, 1740), (0, 1741), (0, 1742)];
        let eps = evaluate_episodes(
            &crate::policy::acting::BotAgent,
            &level,
            &plan,
            0.5,
            ActionMode::Greedy,
            &mut |_| {},
        )
        .unwrap();
        let seeds: Vec<u64> = eps.iter().map(|e| e.level_seed).collect();
        assert_eq!(seeds, [1740, 1742]);
    }

    #[test]
    fn aggregation_goes_episodes_then_seeds() {
        // Seed 0: episodes with acc 1.0 and 0.0 → 0.5; seed 1: one episode with 1.0, one
        // without evaluated steps → 1.0. Mean over seeds 0.75, population std 0.25.
        let eps = [
            ep(0, true, 0.9, Some(1.0)),
            ep(0, false, 0.0, Some(0.0)),
            ep(1, true, 0.5, Some(1.0)),
            ep(1, false, 0.0, None),
        ];
        let g = grounding(&eps, WordKind::Object);
        assert_eq!(
            g.acc,
            MeanStd {
                mean: Some(0.75),
                std: Some(0.25)
            }
        );
        assert_eq!(g.acc_ng.mean, Some(1.0));
        assert_eq!(g.around.len(), 9);
        assert_eq!(g.around[4], g.acc);
        assert_eq!(g.around[8].mean, Some(0.25));
        assert_eq!(g.evaluated_steps, 6);
        assert_eq!(g.episodes_without, 1);
        let p = performance(&eps);
        assert_eq!(
            p.success,
            MeanStd {
                mean: Some(0.5),
                std: Some(0.0)
            }
        );
        assert_eq!(p.reward.mean, Some(f64::midpoint(0.45, 0.25)));
        assert_eq!(p.reward_given_success.mean, Some(f64::midpoint(0.9, 0.5)));
        assert_eq!(grounding(&eps, WordKind::Color).acc.mean, None);
    }

    #[test]
    fn one_seed_shows_its_mean_alone() {
        let one = MeanStd::of(&[0.25]);
        assert_eq!(one.std, Some(0.0), "report.json and the CSVs keep the 0");
        assert_eq!(one.shown(false), "0.250");
        assert_eq!(one.shown(true), "0.250 ± 0.000");
        assert_eq!(one.to_string(), "0.250 ± 0.000");
        assert_eq!(MeanStd::of(&[]).shown(false), "–");
        assert_eq!(MeanStd::of(&[0.0, 1.0]).shown(true), "0.500 ± 0.500");
    }
}
