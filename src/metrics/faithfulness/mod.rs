//! Faithfulness: does the attention explain the behaviour? A consumer of the policy (through
//! [`crate::policy::act_with`] and its [`crate::policy::Intervention`]s) and of the world;
//! definitions in docs/faithfulness.md.
//!
//! Every measure is aggregated like `eval`: over the analysed steps of an episode, then over
//! the episodes of an evaluation seed, then mean ± std over seeds, and every one sits next
//! to its control or chance level.

pub mod episode;
pub mod figures;
pub mod measures;
pub mod report;
pub mod step;

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

pub use episode::{CLOSED_LOOP, COUNTERFACTUALS, Counterfactual, EpisodeResult, Parts, Rollout};
pub use report::{FaithfulnessReport, summarise};

use rand::SeedableRng as _;

use crate::env::level::LevelConfig;
use crate::episode::{ActionMode, EpisodeTrace, InterventionOutcome, StepFaithfulness};
use crate::policy::{Memory, Net, PolicyError, act, trace::to_map};

/// Analyses one episode per `(eval_seed, level_seed)` of `plan` on `jobs` threads; results
/// come back in plan order. `progress` is called after each episode with the number done.
pub fn run(
    net: &Net,
    level: &LevelConfig,
    plan: &[(u64, u64)],
    mode: ActionMode,
    parts: Parts,
    jobs: usize,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<EpisodeResult>, PolicyError> {
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<Result<EpisodeResult, PolicyError>>>> =
        Mutex::new((0..plan.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&(s, seed)) = plan.get(i) else {
                        break;
                    };
                    let r = episode::analyse_episode(net, level, s, seed, mode, parts);
                    let failed = r.is_err();
                    if let Ok(mut v) = slots.lock() {
                        v[i] = Some(r);
                    }
                    progress(done.fetch_add(1, Ordering::Relaxed) + 1);
                    if failed {
                        // Stop the other workers too: the first error is the answer.
                        next.store(plan.len(), Ordering::Relaxed);
                        break;
                    }
                }
            });
        }
    });
    let slots = slots
        .into_inner()
        .map_err(|_| PolicyError::Input("a faithfulness worker panicked".into()))?;
    let mut out = Vec::with_capacity(plan.len());
    for r in slots {
        match r {
            Some(Ok(e)) => out.push(e),
            Some(Err(e)) => return Err(e),
            None => {}
        }
    }
    Ok(out)
}

/// Adds [`StepFaithfulness`] to every step of `trace` (which `net` produced): the memory of
/// each step is rebuilt by feeding the trace's observations again, then the step is analysed
/// with it held fixed. The same trace gives the same numbers.
pub fn annotate(net: &Net, trace: &mut EpisodeTrace) -> Result<(), PolicyError> {
    let tokens = trace.tokens.clone();
    let mut memory = Memory::zeros(1, net.cfg.lstm_hidden)?;
    let mut rng = annotation_rng(trace);
    for s in &mut trace.steps {
        s.faithfulness = Some(step_faithfulness(net, s, &tokens, &memory, &mut rng)?);
        memory = act(net, &[s.obs], &[&tokens], &memory, false)?.memory;
    }
    Ok(())
}

/// The measures of step `k` alone (the debugger's on-demand view): the memory is rebuilt
/// from steps `0..k`. Equal to what [`annotate`] gives step `k` except for the permutation
/// drawn for the `permuted` intervention.
pub fn annotate_step(
    net: &Net,
    trace: &EpisodeTrace,
    k: usize,
) -> Result<StepFaithfulness, PolicyError> {
    let Some(step) = trace.steps.get(k) else {
        return Err(PolicyError::Input(format!(
            "step {k} is past the end of the episode ({} steps)",
            trace.steps.len()
        )));
    };
    let mut memory = Memory::zeros(1, net.cfg.lstm_hidden)?;
    for s in &trace.steps[..k] {
        memory = act(net, &[s.obs], &[&trace.tokens], &memory, false)?.memory;
    }
    step_faithfulness(
        net,
        step,
        &trace.tokens,
        &memory,
        &mut annotation_rng(trace),
    )
}

fn annotation_rng(trace: &EpisodeTrace) -> rand_pcg::Pcg64Mcg {
    rand_pcg::Pcg64Mcg::seed_from_u64(trace.seed ^ 0xFA17_4F11)
}

fn step_faithfulness(
    net: &Net,
    s: &crate::episode::StepRecord,
    tokens: &[u32],
    memory: &Memory,
    rng: &mut rand_pcg::Pcg64Mcg,
) -> Result<StepFaithfulness, PolicyError> {
    let input = step::StepInput {
        net,
        tokens,
        memory,
        obs: s.obs,
        desc: s.world.instr.desc,
        probs: &s.probs,
        action: s.action as usize,
        attention: s.attention.as_ref(),
    };
    let r = step::analyse(&input, rng)?;
    let occlusion: Vec<f32> = r.occlusion.iter().map(|x| *x as f32).collect();
    Ok(StepFaithfulness {
        occlusion: to_map(&occlusion),
        rank_correlation: r.rank_correlation,
        interventions: r
            .interventions
            .iter()
            .map(|(k, e)| {
                (
                    (*k).to_owned(),
                    InterventionOutcome {
                        tv: e.tv,
                        flip: e.flip,
                    },
                )
            })
            .collect(),
    })
}
