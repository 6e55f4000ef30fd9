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

use candle_core::{Device, Tensor};

pub use acting::{Acting, Agent};
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

/// Steps B environments at once with detached weights (no gradient graph is built).
/// `missions[b]` are environment b's tokens; `memory` is (B, H), already reset where an
/// episode starts.
pub fn act(
    net: &Net,
    obs: &[Observation],
    missions: &[&[u32]],
    memory: &Memory,
    with_traces: bool,
) -> Result<ActOutput, PolicyError> {
    act_with(net, obs, missions, memory, with_traces, None)
}

/// [`act`] with an [`Intervention`] on the attention: the returned traces show the changed
/// weights and `M`.
pub fn act_with(
    net: &Net,
    obs: &[Observation],
    missions: &[&[u32]],
    memory: &Memory,
    with_traces: bool,
    intervention: Option<&Intervention>,
) -> Result<ActOutput, PolicyError> {
    same_batch(obs.len(), missions.len(), &[("memories", memory.h.dim(0)?)])?;
    act_encoded(
        net,
        &Encoded::new(obs, missions)?,
        missions,
        memory,
        with_traces,
        intervention,
    )
}

/// A batch's inputs encoded on the host: token batch and cell codes.
pub struct Encoded {
    /// The missions, deduplicated.
    pub tokens: TokenBatch,
    /// The observations' cell codes.
    pub codes: obs::CellCodes,
}

impl Encoded {
    /// Encodes observations and missions (the same length).
    pub fn new(obs: &[Observation], missions: &[&[u32]]) -> Result<Self, PolicyError> {
        Ok(Self {
            tokens: TokenBatch::new(missions)?,
            codes: obs::CellCodes::new(obs),
        })
    }
}

/// The forward half of [`act_with`], from inputs already encoded (so callers can time the
/// two apart); `missions` name the words of the traces.
pub fn act_encoded(
    net: &Net,
    enc: &Encoded,
    missions: &[&[u32]],
    memory: &Memory,
    with_traces: bool,
    intervention: Option<&Intervention>,
) -> Result<ActOutput, PolicyError> {
    let mission = net.mission_inputs(&enc.tokens)?;
    act_prepared(
        net,
        &enc.codes,
        &mission,
        missions,
        memory,
        with_traces,
        intervention,
    )
}

/// The mission's inputs (text code, queries) of a single episode, computed once: they do not
/// change while it runs, and computing them is most of a batch-1 step (the GRU).
pub fn episode_mission(net: &Net, tokens: &[u32]) -> Result<MissionInputs, PolicyError> {
    net.mission_inputs(&TokenBatch::new(&[tokens])?)
}

/// [`act_with`] for one environment whose mission inputs come from [`episode_mission`]: the
/// same numbers as recomputing them, without the recomputation.
pub fn act_episode(
    net: &Net,
    obs: Observation,
    tokens: &[u32],
    mission: &MissionInputs,
    memory: &Memory,
    with_traces: bool,
    intervention: Option<&Intervention>,
) -> Result<ActOutput, PolicyError> {
    act_prepared(
        net,
        &obs::CellCodes::new(&[obs]),
        mission,
        &[tokens],
        memory,
        with_traces,
        intervention,
    )
}

/// [`act`] for B environments whose mission inputs were computed beforehand (once for many
/// steps, then [`MissionInputs::select`]ed): the same numbers as recomputing them.
pub fn act_missions(
    net: &Net,
    obs: &[Observation],
    missions: &[&[u32]],
    mission: &MissionInputs,
    memory: &Memory,
    with_traces: bool,
    intervention: Option<&Intervention>,
) -> Result<ActOutput, PolicyError> {
    same_batch(
        obs.len(),
        missions.len(),
        &[
            ("mission inputs", mission.text.dim(0)?),
            ("memories", memory.h.dim(0)?),
        ],
    )?;
    act_prepared(
        net,
        &obs::CellCodes::new(obs),
        mission,
        missions,
        memory,
        with_traces,
        intervention,
    )
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

fn act_prepared(
    net: &Net,
    codes: &obs::CellCodes,
    mission: &MissionInputs,
    missions: &[&[u32]],
    memory: &Memory,
    with_traces: bool,
    intervention: Option<&Intervention>,
) -> Result<ActOutput, PolicyError> {
    let (logits, values, memory, vis) = net.step_with(codes, mission, memory, intervention)?;
    let traces = match (&vis.attention, with_traces) {
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
