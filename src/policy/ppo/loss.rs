//! One minibatch shard's forward and backward pass, and the PPO loss.

use candle_core::backprop::GradStore;
use candle_core::{D, DType, Device, Tensor};

use super::ground::{FrameTargets, ground_loss};
use super::rollout::Rollout;
use super::{PhaseTimes, PpoConfig, secs};
use crate::env::view::Observation;
use crate::policy::error::PolicyError;
use crate::policy::model::{Memory, Net, log_probs};
use crate::policy::obs::{self, TokenBatch};

/// One chunk step's LSTM `h` and `c` rows on the host, one row per sequence.
pub(super) type HostMemory = (Vec<Vec<f32>>, Vec<Vec<f32>>);

/// What one shard of a minibatch gives back besides its gradient: its mean losses and the memories
/// it computed at chunk steps 1..rec (for torch-ac's in-place refresh).
pub(super) struct ShardOut {
    pub(super) policy: f64,
    pub(super) value: f64,
    pub(super) entropy: f64,
    /// The unweighted grounding term (`--ground-loss`; 0 without it or with no target in view).
    pub(super) ground: f64,
    pub(super) mems: Vec<HostMemory>,
    pub(super) times: PhaseTimes,
}

/// Forward and backward of the sequences starting at `starts` (read-only on the rollout, so
/// shards can run on threads side by side).
pub(super) fn shard_step(
    net: &Net,
    ro: &Rollout,
    starts: &[usize],
    ppo: &PpoConfig,
) -> Result<(GradStore, ShardOut), PolicyError> {
    let encode_t = std::time::Instant::now();
    let rec = ppo.recurrence;
    let hid = net.cfg.lstm_hidden;
    let n = starts.len();
    // Frames of the shard, t-major: row k·n + j is frame starts[j] + k.
    let rows: Vec<usize> = (0..rec)
        .flat_map(|k| starts.iter().map(move |&s| s + k))
        .collect();
    let obs_b: Vec<Observation> = rows.iter().map(|&i| ro.obs[i]).collect();
    let missions: Vec<&[u32]> = rows.iter().map(|&i| ro.tokens[i].as_slice()).collect();
    let tb = TokenBatch::new(&missions)?;
    let codes = obs::CellCodes::new(&obs_b);
    let gather = |v: &[f32]| -> Result<Tensor, PolicyError> {
        let d: Vec<f32> = rows.iter().map(|&i| v[i]).collect();
        Ok(Tensor::from_vec(d, rows.len(), &Device::Cpu)?)
    };
    let keep = gather(&ro.masks)?.reshape((rec, n))?;
    let h0: Vec<f32> = starts
        .iter()
        .flat_map(|&s| ro.h[s].iter().copied())
        .collect();
    let c0: Vec<f32> = starts
        .iter()
        .flat_map(|&s| ro.c[s].iter().copied())
        .collect();
    let mem0 = Memory {
        h: Tensor::from_vec(h0, (n, hid), &Device::Cpu)?,
        c: Tensor::from_vec(c0, (n, hid), &Device::Cpu)?,
    };
    let mut times = PhaseTimes {
        update_encode: secs(encode_t),
        ..PhaseTimes::default()
    };
    let forward_t = std::time::Instant::now();
    let ground = ppo.ground_loss > 0.0;
    let seq = net.sequence_with_maps(&codes, &tb, &mem0, &keep, ground)?;
    let (logits, values) = (seq.logits, seq.values);
    let mems = seq
        .mems
        .iter()
        .take(rec - 1)
        .map(|m| Ok((m.h.to_vec2::<f32>()?, m.c.to_vec2::<f32>()?)))
        .collect::<Result<Vec<_>, PolicyError>>()?;
    let actions = Tensor::from_vec(
        rows.iter().map(|&i| ro.actions[i]).collect::<Vec<u32>>(),
        (rows.len(), 1),
        &Device::Cpu,
    )?;
    let (old_values, returns) = (gather(&ro.values)?, gather(&ro.returns)?);
    let losses = if ppo.imitate {
        imitation_loss(
            &logits,
            &values,
            &actions,
            &gather(&ro.expert)?,
            &old_values,
            &returns,
            ppo,
        )?
    } else {
        ppo_loss(
            &logits,
            &values,
            &actions,
            &gather(&ro.logps)?,
            &old_values,
            &gather(&ro.advantages)?,
            &returns,
            ppo,
        )?
    };
    let mut total = losses.total;
    let mut ground_term = 0.0;
    if let Some((a, m)) = &seq.maps {
        let frames: Vec<&FrameTargets> = rows.iter().map(|&i| &ro.targets[i]).collect();
        if let Some((weighted, plain)) = ground_loss(a, m, &frames, ppo.ground_loss)? {
            total = (total + weighted)?;
            ground_term = plain;
        }
    }
    times.update_forward = secs(forward_t);
    let backward_t = std::time::Instant::now();
    let grads = total.backward()?;
    times.update_backward = secs(backward_t);
    let out = ShardOut {
        times,
        policy: f64::from(losses.policy.to_scalar::<f32>()?),
        value: f64::from(losses.value.to_scalar::<f32>()?),
        entropy: f64::from(losses.entropy.to_scalar::<f32>()?),
        ground: ground_term,
        mems,
    };
    Ok((grads, out))
}

/// The terms of the PPO loss for one minibatch.
pub struct PpoLosses {
    /// `policy − c_ent·entropy + c_v·value`, what is minimised.
    pub total: Tensor,
    /// `−mean(min(r·A, clip(r)·A))`.
    pub policy: Tensor,
    /// `mean(max((V − R)², (V_clip − R)²))`.
    pub value: Tensor,
    /// Mean entropy of the action distribution.
    pub entropy: Tensor,
}

/// torch-ac's PPO loss (the one place it is written).
#[expect(
    clippy::too_many_arguments,
    reason = "the loss's inputs, named as in torch-ac"
)]
pub fn ppo_loss(
    logits: &Tensor,
    values: &Tensor,
    actions: &Tensor,
    old_logp: &Tensor,
    old_values: &Tensor,
    adv: &Tensor,
    returns: &Tensor,
    cfg: &PpoConfig,
) -> Result<PpoLosses, PolicyError> {
    let clip = cfg.clip_eps;
    let (logp, entropy, value) = shared_terms(logits, values, actions, old_values, returns, cfg)?;
    let ratio = (logp - old_logp)?.exp()?;
    let surr1 = (&ratio * adv)?;
    let surr2 = (ratio.clamp(1.0 - clip, 1.0 + clip)? * adv)?;
    let policy = surr1.minimum(&surr2)?.mean_all()?.neg()?;
    combine(policy, entropy, value, cfg)
}

/// What PPO and imitation share: the log-probability of each taken action, the mean
/// entropy, and the clipped value loss `mean(max((V − R)², (V_clip − R)²))`.
fn shared_terms(
    logits: &Tensor,
    values: &Tensor,
    actions: &Tensor,
    old_values: &Tensor,
    returns: &Tensor,
    cfg: &PpoConfig,
) -> Result<(Tensor, Tensor, Tensor), PolicyError> {
    let clip = cfg.clip_eps;
    let logp_all = log_probs(logits)?;
    let entropy = (logp_all.exp()? * &logp_all)?
        .sum(D::Minus1)?
        .mean_all()?
        .neg()?;
    let logp = logp_all.gather(actions, 1)?.squeeze(1)?;
    let v_clipped = (old_values + (values - old_values)?.clamp(-clip, clip)?)?;
    let l1 = (values - returns)?.sqr()?;
    let l2 = (v_clipped - returns)?.sqr()?;
    let value = l1.maximum(&l2)?.mean_all()?;
    Ok((logp, entropy, value))
}

/// `policy − c_ent·entropy + c_v·value`.
fn combine(
    policy: Tensor,
    entropy: Tensor,
    value: Tensor,
    cfg: &PpoConfig,
) -> Result<PpoLosses, PolicyError> {
    let total = ((&policy - (&entropy * cfg.entropy_coef)?)? + (&value * cfg.value_loss_coef)?)?;
    Ok(PpoLosses {
        total,
        policy,
        value,
        entropy,
    })
}

/// Behavioural cloning's loss (`train --imitate`): the policy term becomes the cross-entropy
/// of the policy on the bot's actions, averaged over the frames that carry one (`expert` = 1);
/// the entropy bonus and the value loss stay PPO's.
pub fn imitation_loss(
    logits: &Tensor,
    values: &Tensor,
    actions: &Tensor,
    expert: &Tensor,
    old_values: &Tensor,
    returns: &Tensor,
    cfg: &PpoConfig,
) -> Result<PpoLosses, PolicyError> {
    let (logp, entropy, value) = shared_terms(logits, values, actions, old_values, returns, cfg)?;
    let frames = expert.sum_all()?.to_scalar::<f32>()?.max(1.0);
    let policy = ((logp * expert)?.sum_all()? / f64::from(frames))?.neg()?;
    combine(policy, entropy, value, cfg)
}

/// Converts the optimizer's step count and tensors to safetensors-ready f32 data.
pub fn tensor_to_vec(t: &Tensor) -> Result<Vec<f32>, PolicyError> {
    Ok(t.to_dtype(DType::F32)?.flatten_all()?.to_vec1::<f32>()?)
}
