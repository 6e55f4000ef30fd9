//! Faithfulness: does the attention explain the behaviour? A consumer of the policy (any
//! [`crate::policy::Acting`]: a native network or an imported graph, with its
//! [`crate::policy::Intervention`]s where it takes them) and of the world; definitions in
//! docs/faithfulness.md.
//!
//! Every measure is aggregated like `eval`: over the analysed steps of an episode, then over
//! the episodes of an evaluation seed, then mean ± std over seeds, and every one sits next
//! to its control or chance level.

pub mod episode;
pub mod figures;
pub mod measures;
pub mod peaks;
pub mod report;
pub mod step;

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

pub use episode::{CLOSED_LOOP, COUNTERFACTUALS, Counterfactual, EpisodeResult, Parts, Rollout};
pub use report::{FaithfulnessReport, summarise};

use rand::SeedableRng as _;

use crate::env::level::LevelConfig;
use crate::episode::{ActionMode, EpisodeTrace, InterventionOutcome, StepFaithfulness};
use crate::policy::{Acting, PolicyError, Step, trace::to_map};

/// Analyses one episode per `(eval_seed, level_seed)` of `plan` on `jobs` threads; results
/// come back in plan order. `progress` is called after each episode with the number done.
pub fn run(
    agent: &(dyn Acting + Sync),
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
                    // A panic is this episode's error: the scope would otherwise panic
                    // itself once every other worker had finished.
                    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        episode::analyse_episode(agent, level, s, seed, mode, parts)
                    }))
                    .unwrap_or_else(|p| {
                        Err(PolicyError::Input(format!(
                            "{level} seed {seed}: a worker failed: {}",
                            crate::panics::panic_line(p.as_ref())
                        )))
                    });
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

/// Adds [`StepFaithfulness`] to every step of `trace` (which `agent` produced): the memory of
/// each step is rebuilt by feeding the trace's observations again, then the step is analysed
/// with it held fixed. The same trace gives the same numbers.
pub fn annotate(agent: &(dyn Acting + Sync), trace: &mut EpisodeTrace) -> Result<(), PolicyError> {
    let tokens = trace.tokens.clone();
    let mut memory = agent.zero_memory()?;
    let mut rng = annotation_rng(trace);
    for s in &mut trace.steps {
        s.faithfulness = Some(step_faithfulness(agent, s, &tokens, &memory, &mut rng)?);
        memory = feed(agent, s, &tokens, &memory)?;
    }
    Ok(())
}

/// The memory after step `s`, from the memory before it.
fn feed(
    agent: &(dyn Acting + Sync),
    s: &crate::episode::StepRecord,
    tokens: &[u32],
    memory: &crate::policy::Memory,
) -> Result<crate::policy::Memory, PolicyError> {
    Ok(agent
        .act_step(&Step::one(&s.obs, &s.world.agent_dir, &tokens, memory))?
        .memory)
}

/// The measures of step `k` alone (the debugger's on-demand view): the memory is rebuilt
/// from steps `0..k`. Equal to what [`annotate`] gives step `k` except for the permutation
/// drawn for the `permuted` intervention.
pub fn annotate_step(
    agent: &(dyn Acting + Sync),
    trace: &EpisodeTrace,
    k: usize,
) -> Result<StepFaithfulness, PolicyError> {
    let Some(step) = trace.steps.get(k) else {
        return Err(PolicyError::Input(format!(
            "step {k} is past the end of the episode ({} steps)",
            trace.steps.len()
        )));
    };
    let mut memory = agent.zero_memory()?;
    for s in &trace.steps[..k] {
        memory = feed(agent, s, &trace.tokens, &memory)?;
    }
    step_faithfulness(
        agent,
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
    agent: &(dyn Acting + Sync),
    s: &crate::episode::StepRecord,
    tokens: &[u32],
    memory: &crate::policy::Memory,
    rng: &mut rand_pcg::Pcg64Mcg,
) -> Result<StepFaithfulness, PolicyError> {
    let input = step::StepInput {
        agent,
        direction: s.world.agent_dir,
        tokens,
        memory,
        obs: s.obs,
        words: crate::env::targets::word_targets(&s.world, &s.obs, tokens.len()),
        targets: crate::metrics::grounding::pending_targets(&s.world, &s.obs),
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
