//! The policy: the paper's text-visual attention network and its no-attention baseline
//! (candle), attention traces, checkpoints.

pub mod acting;
pub mod attention;
pub mod bundled;
pub mod checkpoint;
pub mod config;
pub mod error;
pub mod kernels;
pub mod model;
pub mod obs;
pub mod onnx;
pub mod params;
pub mod ppo;
pub mod trace;
pub mod weights;

use candle_core::{Device, Tensor};

pub use acting::{Acting, Agent, Step};
pub use attention::Intervention;
pub use checkpoint::{Checkpoint, CheckpointMeta, TrainingState, checkpoint_paths};
pub use config::{AttendWords, ColourCodes, ModelConfig, Variant, WordTemperature};
pub use error::PolicyError;
pub use model::{Memory, MissionInputs, Net};
pub use obs::TokenBatch;
pub use params::Params;
pub use trace::{AttentionTrace, ViewMap, WordAttention};

use crate::env::view::Observation;

/// What one batched, gradient-free step returns for B environments.
#[derive(Clone, Debug)]
pub struct ActOutput {
    /// (B, 7) action logits.
    pub logits: Vec<Vec<f32>>,
    /// (B, 7) action probabilities.
    pub probs: Vec<Vec<f32>>,
    /// (B,) critic values.
    pub values: Vec<f32>,
    /// The memory after the step.
    pub memory: Memory,
    /// One trace per environment (attention variant, when asked for).
    pub traces: Option<Vec<AttentionTrace>>,
}

/// How [`act`] steps: whether it returns attention traces, an [`Intervention`] on the
/// attention (the traces then show the changed weights and `M`), and the batch's mission
/// inputs when they were computed before — once per episode ([`episode_mission`]), or once for
/// many steps and [`MissionInputs::select`]ed — which gives the same numbers as computing them.
#[derive(Clone, Copy, Default)]
pub struct ActOptions<'a> {
    /// Return one attention trace per environment (attention variant).
    pub traces: bool,
    /// Change the attention inside the forward pass.
    pub intervention: Option<&'a Intervention>,
    /// The missions' inputs, computed before.
    pub prepared: Option<&'a MissionInputs>,
}

/// Steps B environments at once with detached weights (no gradient graph is built): the one
/// entry for acting. `missions[b]` are environment b's tokens; `memory` is (B, H), already
/// reset where an episode starts.
pub fn act(
    net: &Net,
    obs: &[Observation],
    missions: &[&[u32]],
    memory: &Memory,
    opts: ActOptions<'_>,
) -> Result<ActOutput, PolicyError> {
    same_batch(obs.len(), missions.len(), &[("memories", memory.h.dim(0)?)])?;
    let owned;
    let mission = if let Some(m) = opts.prepared {
        same_batch(
            obs.len(),
            missions.len(),
            &[("mission inputs", m.text.dim(0)?)],
        )?;
        m
    } else {
        owned = net.mission_inputs(&TokenBatch::new(missions)?)?;
        &owned
    };
    let codes = obs::CellCodes::new(obs);
    let (logits, values, memory, vis) =
        net.step_with(&codes, mission, memory, opts.intervention)?;
    let traces = match (&vis.attention, opts.traces) {
        (Some(att), true) => Some(trace::extract(att, missions)?),
        _ => None,
    };
    Ok(ActOutput {
        probs: model::probs_host(&logits)?,
        logits: logits.to_vec2::<f32>()?,
        values: values.to_vec1::<f32>()?,
        memory,
        traces,
    })
}

/// Inverse-CDF sampling: the first action whose cumulative probability exceeds `u` ∈ [0, 1)
/// (the last one where rounding leaves the sum below `u`). Training's rollout and a sampled
/// episode draw their actions with it, so a seed picks the same action in both.
pub fn sample_index(probs: &[f32], u: f32) -> usize {
    let mut acc = 0.0;
    probs
        .iter()
        .position(|&q| {
            acc += q;
            u < acc
        })
        .unwrap_or(probs.len().saturating_sub(1))
}

/// The mission's inputs (text code, queries) of a single episode, computed once: they do not
/// change while it runs, and computing them is most of a batch-1 step (the GRU).
pub fn episode_mission(net: &Net, tokens: &[u32]) -> Result<MissionInputs, PolicyError> {
    net.mission_inputs(&TokenBatch::new(&[tokens])?)
}

/// Checks that a batch's parts have one row per observation, naming the sizes if not.
fn same_batch(obs: usize, missions: usize, others: &[(&str, usize)]) -> Result<(), PolicyError> {
    if missions == obs && others.iter().all(|(_, n)| *n == obs) {
        return Ok(());
    }
    let parts: Vec<String> = [(obs, "observations"), (missions, "missions")]
        .into_iter()
        .chain(others.iter().map(|(what, n)| (*n, *what)))
        .map(|(n, what)| format!("{n} {what}"))
        .collect();
    Err(PolicyError::Input(format!(
        "batch sizes differ: {}",
        parts.join(", ")
    )))
}

/// A (B,) f32 tensor on the CPU.
pub fn vec_tensor(v: Vec<f32>) -> Result<Tensor, PolicyError> {
    let n = v.len();
    Ok(Tensor::from_vec(v, n, &Device::Cpu)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mismatched_batches_name_every_size() {
        assert!(same_batch(3, 3, &[("memories", 3)]).is_ok());
        let err = same_batch(3, 2, &[("mission inputs", 3), ("memories", 1)])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("3 observations, 2 missions, 3 mission inputs, 1 memories"),
            "{err}"
        );
    }
}
