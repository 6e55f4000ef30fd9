//! Recurrent PPO as torch-ac does it: P environments stepped together for T frames, GAE,
//! clipped policy and value losses, an entropy bonus, BPTT over chunks of `recurrence` frames
//! with episode masks (stored memories refreshed during the epochs), global grad-norm
//! clipping, Adam.
//!
//! Buffers are proc-major (frame `i = p·T + t`), as torch-ac's; minibatches are t-major inside
//! (row = k·n + j for step k of sequence j). Training level seeds start at
//! [`TRAIN_SEED_OFFSET`], so evaluation seeds (small integers) are never trained on.

use std::collections::BTreeMap;

use candle_core::backprop::GradStore;
use candle_core::{D, DType, Device, Tensor};
use rand::seq::SliceRandom as _;
use rand::{Rng as _, SeedableRng as _};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use super::ModelConfig;
use super::adam::{Adam, AdamConfig, clip_grad_norm};
use super::error::PolicyError;
use super::model::{Memory, Net, log_probs};
use super::obs::{self, TokenBatch};
use super::params::Params;
use crate::env::level::LevelConfig;
use crate::env::view::Observation;
use crate::env::vocab;
use crate::env::world::{Action, World};

/// Level seeds used in training are `TRAIN_SEED_OFFSET + k`.
pub const TRAIN_SEED_OFFSET: u64 = 1 << 32;

/// A warm-started run's level seeds start this far past its parent's frame count, which is
/// more than any parent's number of environments.
const WARM_START_SEED_GAP: u64 = 1 << 16;

/// The longest mission a run state may hold (BabyAI's local missions have at most 9 words).
const MAX_STATE_TOKENS: usize = 64;

/// PPO hyper-parameters (torch-ac's defaults).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PpoConfig {
    /// Environments stepped together.
    pub procs: usize,
    /// Frames per environment per update.
    pub frames_per_proc: usize,
    /// Epochs over each rollout.
    pub epochs: usize,
    /// Frames per minibatch.
    pub batch_size: usize,
    /// BPTT chunk length.
    pub recurrence: usize,
    /// Adam learning rate.
    pub lr: f64,
    /// Adam ε.
    pub adam_eps: f64,
    /// Discount γ.
    pub discount: f64,
    /// GAE λ.
    pub gae_lambda: f64,
    /// Entropy bonus coefficient.
    pub entropy_coef: f64,
    /// Value loss coefficient.
    pub value_loss_coef: f64,
    /// Gradient-norm clip.
    pub max_grad_norm: f64,
    /// PPO clip ε (ratio and value).
    pub clip_eps: f64,
    /// Threads that share each minibatch's forward and backward pass, each on its share of
    /// the sequences; their gradients are summed in shard order, so a run is deterministic
    /// for a given count (runs saved before the flag existed used 1).
    #[serde(default = "one_thread")]
    pub update_threads: usize,
    /// Rewards are multiplied by this before GAE and the value loss (BabyAI uses 20, which
    /// makes the entropy bonus 20× weaker relative to the returns); logs stay unscaled.
    #[serde(default = "unit_scale")]
    pub reward_scale: f64,
    /// Normalise the advantages of each rollout to mean 0 and standard deviation 1 before the
    /// epochs (over the whole rollout, so the result does not depend on `update_threads`).
    #[serde(default)]
    pub normalize_advantages: bool,
}

fn one_thread() -> usize {
    1
}

fn unit_scale() -> f64 {
    1.0
}

impl Default for PpoConfig {
    fn default() -> Self {
        Self {
            procs: 16,
            frames_per_proc: 128,
            epochs: 4,
            batch_size: 256,
            recurrence: 4,
            lr: 1e-3,
            adam_eps: 1e-8,
            discount: 0.99,
            gae_lambda: 0.95,
            entropy_coef: 0.01,
            value_loss_coef: 0.5,
            max_grad_norm: 0.5,
            clip_eps: 0.2,
            update_threads: 1,
            reward_scale: 1.0,
            normalize_advantages: false,
        }
    }
}

impl PpoConfig {
    /// Checks the divisibility torch-ac asserts, naming the flag.
    pub fn validate(&self) -> Result<(), PolicyError> {
        let bad = |m: String| Err(PolicyError::Input(m));
        if self.procs == 0
            || self.frames_per_proc == 0
            || self.epochs == 0
            || self.recurrence == 0
            || self.update_threads == 0
        {
            return bad(
                "--procs, --frames-per-proc, --epochs, --recurrence and --update-threads must be positive"
                    .into(),
            );
        }
        if !self.frames_per_proc.is_multiple_of(self.recurrence) {
            return bad(format!(
                "--frames-per-proc {} is not a multiple of --recurrence {}",
                self.frames_per_proc, self.recurrence
            ));
        }
        if !self.batch_size.is_multiple_of(self.recurrence) || self.batch_size == 0 {
            return bad(format!(
                "--batch-size {} is not a positive multiple of --recurrence {}",
                self.batch_size, self.recurrence
            ));
        }
        for (name, v) in [
            ("--lr", self.lr),
            ("--discount", self.discount),
            ("--gae-lambda", self.gae_lambda),
            ("--clip-eps", self.clip_eps),
            ("--max-grad-norm", self.max_grad_norm),
            ("--reward-scale", self.reward_scale),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{name} {v} must be a positive number"));
            }
        }
        Ok(())
    }

    /// Frames collected per update.
    pub fn frames_per_update(&self) -> usize {
        self.procs * self.frames_per_proc
    }
}

/// One environment slot of the rollout.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct EnvSlot {
    world: World,
    tokens: Vec<u32>,
    h: Vec<f32>,
    c: Vec<f32>,
    /// 1 − done of the previous step.
    mask: f32,
    ep_return: f64,
    ep_len: u32,
}

/// Episode statistics since the last log line.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct EpisodeStats {
    /// Episodes finished.
    pub episodes: u64,
    /// Of which successful.
    pub successes: u64,
    /// Sum of returns.
    pub return_sum: f64,
    /// Sum of lengths.
    pub length_sum: u64,
}

/// Everything a run needs to continue exactly (`--resume`), besides the weights and Adam.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunState {
    /// Updates done.
    pub updates: u64,
    /// Frames collected.
    pub frames: u64,
    /// Next training level seed (minus [`TRAIN_SEED_OFFSET`]).
    pub next_seed: u64,
    /// Action sampling RNG.
    act_rng: Pcg64Mcg,
    /// Minibatch shuffling RNG.
    batch_rng: Pcg64Mcg,
    /// torch-ac's alternating-offset counter.
    batch_num: u64,
    envs: Vec<EnvSlot>,
}

/// What one update logged.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct UpdateLog {
    /// Update index (1-based).
    pub update: u64,
    /// Frames so far.
    pub frames: u64,
    /// Episodes finished in this update's rollout.
    pub episodes: u64,
    /// Their success rate (NaN when none finished).
    pub success_rate: f64,
    /// Their mean return.
    pub mean_reward: f64,
    /// Their mean length.
    pub mean_length: f64,
    /// Mean policy loss over minibatches.
    pub policy_loss: f64,
    /// Mean value loss.
    pub value_loss: f64,
    /// Mean policy entropy (nats).
    pub entropy: f64,
    /// Mean pre-clip gradient norm.
    pub grad_norm: f64,
}

/// A PPO trainer over one level.
pub struct Trainer {
    /// Network sizes.
    pub model: ModelConfig,
    /// The level trained on.
    pub level: LevelConfig,
    /// Hyper-parameters.
    pub ppo: PpoConfig,
    /// Weights.
    pub params: Params,
    /// Optimiser.
    pub adam: Adam,
    /// Progress and RNG streams.
    pub state: RunState,
    /// Wall time per phase, summed over the updates of this process (not saved).
    pub times: PhaseTimes,
}

/// Seconds spent in each phase of training (`groundscope bench train`). With
/// `--update-threads` above 1 the update phases add up the shards' threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PhaseTimes {
    /// Environment steps, observations and rollout bookkeeping.
    pub rollout_env: f64,
    /// Encoding the rollout's inputs: cell codes, token batches, memory tensors.
    pub rollout_encode: f64,
    /// The rollout's batched forward passes (and reading their outputs back).
    pub rollout_forward: f64,
    /// Advantages and returns (GAE).
    pub gae: f64,
    /// Encoding the minibatches' inputs (cell codes, gathers).
    pub update_encode: f64,
    /// Minibatch forward passes and losses.
    pub update_forward: f64,
    /// Backward passes.
    pub update_backward: f64,
    /// Merging shard gradients, clipping and Adam.
    pub optimizer: f64,
}

impl PhaseTimes {
    /// The phases by name, in order.
    pub fn named(&self) -> [(&'static str, f64); 8] {
        [
            ("rollout_env", self.rollout_env),
            ("rollout_encode", self.rollout_encode),
            ("rollout_forward", self.rollout_forward),
            ("gae", self.gae),
            ("update_encode", self.update_encode),
            ("update_forward", self.update_forward),
            ("update_backward", self.update_backward),
            ("optimizer", self.optimizer),
        ]
    }

    fn add(&mut self, o: &Self) {
        self.rollout_env += o.rollout_env;
        self.rollout_encode += o.rollout_encode;
        self.rollout_forward += o.rollout_forward;
        self.gae += o.gae;
        self.update_encode += o.update_encode;
        self.update_forward += o.update_forward;
        self.update_backward += o.update_backward;
        self.optimizer += o.optimizer;
    }
}

fn secs(t: std::time::Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

/// Rollout buffers, proc-major.
struct Rollout {
    obs: Vec<Observation>,
    tokens: Vec<Vec<u32>>,
    actions: Vec<u32>,
    values: Vec<f32>,
    logps: Vec<f32>,
    rewards: Vec<f32>,
    masks: Vec<f32>,
    h: Vec<Vec<f32>>,
    c: Vec<Vec<f32>>,
    advantages: Vec<f32>,
    returns: Vec<f32>,
}

impl Trainer {
    /// A fresh run: weights from `seed`, P environments on the first training seeds.
    pub fn new(
        model: ModelConfig,
        level: LevelConfig,
        ppo: PpoConfig,
        params: Params,
        seed: u64,
    ) -> Result<Self, PolicyError> {
        ppo.validate()?;
        level.validate()?;
        let adam = Adam::new(
            AdamConfig {
                lr: ppo.lr,
                beta1: 0.9,
                beta2: 0.999,
                eps: ppo.adam_eps,
            },
            &params.vars,
        )?;
        let mut next_seed = 0;
        let mut envs = Vec::with_capacity(ppo.procs);
        for _ in 0..ppo.procs {
            envs.push(new_slot(&level, next_seed, model.lstm_hidden)?);
            next_seed += 1;
        }
        Ok(Self {
            model,
            level,
            ppo,
            params,
            adam,
            state: RunState {
                updates: 0,
                frames: 0,
                next_seed,
                act_rng: Pcg64Mcg::seed_from_u64(seed ^ 0xA11C_E5ED),
                batch_rng: Pcg64Mcg::seed_from_u64(seed ^ 0xBA7C_4E5D),
                batch_num: 0,
                envs,
            },
            times: PhaseTimes::default(),
        })
    }

    /// A new run that starts from trained weights (`train --init`): fresh Adam moments and
    /// RNG streams, but the frame and update counters continue from `frames` / `updates`, so
    /// budgets and logs count the parent run's frames too. Level seeds start past any the
    /// parent can have used: it started at most `frames + procs` episodes.
    pub fn warm_start(
        model: ModelConfig,
        level: LevelConfig,
        ppo: PpoConfig,
        params: Params,
        seed: u64,
        frames: u64,
        updates: u64,
    ) -> Result<Self, PolicyError> {
        let mut trainer = Self::new(model, level, ppo, params, seed)?;
        let first = frames + WARM_START_SEED_GAP;
        for (k, slot) in trainer.state.envs.iter_mut().enumerate() {
            *slot = new_slot(&level, first + k as u64, model.lstm_hidden)?;
        }
        trainer.state.next_seed = first + ppo.procs as u64;
        trainer.state.frames = frames;
        trainer.state.updates = updates;
        Ok(trainer)
    }

    /// Collects one rollout and runs the PPO epochs on it.
    pub fn update(&mut self) -> Result<UpdateLog, PolicyError> {
        let (mut ro, stats) = self.collect()?;
        let mut log = self.optimise(&mut ro)?;
        self.state.updates += 1;
        self.state.frames += self.ppo.frames_per_update() as u64;
        log.update = self.state.updates;
        log.frames = self.state.frames;
        log.episodes = stats.episodes;
        let n = stats.episodes as f64;
        log.success_rate = stats.successes as f64 / n;
        log.mean_reward = stats.return_sum / n;
        log.mean_length = stats.length_sum as f64 / n;
        for (name, v) in [
            ("policy loss", log.policy_loss),
            ("value loss", log.value_loss),
            ("entropy", log.entropy),
            ("gradient norm", log.grad_norm),
        ] {
            if !v.is_finite() {
                return Err(PolicyError::Input(format!(
                    "{name} is {v} at update {}: training diverged",
                    self.state.updates
                )));
            }
        }
        for (name, var) in &self.params.vars {
            let s = var.as_tensor().sum_all()?.to_scalar::<f32>()?;
            if !s.is_finite() {
                return Err(PolicyError::Input(format!(
                    "weight {name} became {s} at update {}: training diverged",
                    self.state.updates
                )));
            }
        }
        Ok(log)
    }

    fn collect(&mut self) -> Result<(Rollout, EpisodeStats), PolicyError> {
        let (p_n, t_n, hid) = (
            self.ppo.procs,
            self.ppo.frames_per_proc,
            self.model.lstm_hidden,
        );
        let n = p_n * t_n;
        let net = Net::new(self.model, self.params.detached());
        let mut ro = Rollout {
            obs: vec![
                Observation {
                    image: [[[0; 3]; 7]; 7]
                };
                n
            ],
            tokens: vec![Vec::new(); n],
            actions: vec![0; n],
            values: vec![0.0; n],
            logps: vec![0.0; n],
            rewards: vec![0.0; n],
            masks: vec![0.0; n],
            h: vec![Vec::new(); n],
            c: vec![Vec::new(); n],
            advantages: vec![0.0; n],
            returns: vec![0.0; n],
        };
        let mut stats = EpisodeStats::default();
        for t in 0..t_n {
            let out = self.act_all(&net)?;
            let env_t = std::time::Instant::now();
            let st = &mut self.state;
            for (p, env) in st.envs.iter_mut().enumerate() {
                let i = p * t_n + t;
                let probs = &out.probs[p];
                let u: f32 = st.act_rng.random();
                let mut acc = 0.0;
                let a = probs
                    .iter()
                    .position(|&q| {
                        acc += q;
                        u < acc
                    })
                    .unwrap_or(probs.len() - 1);
                ro.obs[i] = env.world.observe();
                ro.tokens[i].clone_from(&env.tokens);
                ro.actions[i] = a as u32;
                ro.values[i] = out.values[p];
                ro.logps[i] = probs[a].max(1e-12).ln();
                ro.masks[i] = env.mask;
                ro.h[i].clone_from(&env.h);
                ro.c[i].clone_from(&env.c);
                let action = Action::from_index(a).unwrap_or(Action::Done);
                let outcome = env.world.step(action)?;
                ro.rewards[i] = (outcome.reward * self.ppo.reward_scale) as f32;
                env.h.clone_from(&out.h[p]);
                env.c.clone_from(&out.c[p]);
                env.ep_return += outcome.reward;
                env.ep_len += 1;
                if outcome.terminated || outcome.truncated {
                    stats.episodes += 1;
                    stats.successes += u64::from(outcome.reward > 0.0);
                    stats.return_sum += env.ep_return;
                    stats.length_sum += u64::from(env.ep_len);
                    let fresh = new_slot(&self.level, st.next_seed, hid)?;
                    st.next_seed += 1;
                    *env = EnvSlot {
                        mask: 0.0,
                        h: std::mem::take(&mut env.h),
                        c: std::mem::take(&mut env.c),
                        ..fresh
                    };
                } else {
                    env.mask = 1.0;
                }
            }
            self.times.rollout_env += secs(env_t);
        }
        // Bootstrap values with the memory the next step would use.
        let last = self.act_all(&net)?;
        let gae_t = std::time::Instant::now();
        let (gamma, lambda) = (self.ppo.discount as f32, self.ppo.gae_lambda as f32);
        for p in 0..p_n {
            let mut next_adv = 0.0;
            for t in (0..t_n).rev() {
                let i = p * t_n + t;
                let (next_mask, next_value) = if t + 1 < t_n {
                    (ro.masks[i + 1], ro.values[i + 1])
                } else {
                    (self.state.envs[p].mask, last.values[p])
                };
                let delta = ro.rewards[i] + gamma * next_value * next_mask - ro.values[i];
                next_adv = delta + gamma * lambda * next_adv * next_mask;
                ro.advantages[i] = next_adv;
                ro.returns[i] = ro.values[i] + next_adv;
            }
        }
        if self.ppo.normalize_advantages {
            normalize(&mut ro.advantages);
        }
        self.times.gae += secs(gae_t);
        Ok((ro, stats))
    }

    /// One gradient-free step for every environment with its masked memory.
    fn act_all(&mut self, net: &Net) -> Result<ActAll, PolicyError> {
        let encode_t = std::time::Instant::now();
        let hid = self.model.lstm_hidden;
        let envs = &self.state.envs;
        let obs: Vec<Observation> = envs.iter().map(|e| e.world.observe()).collect();
        let missions: Vec<&[u32]> = envs.iter().map(|e| e.tokens.as_slice()).collect();
        let mut h = Vec::with_capacity(envs.len() * hid);
        let mut c = Vec::with_capacity(envs.len() * hid);
        for e in envs {
            h.extend(e.h.iter().map(|x| x * e.mask));
            c.extend(e.c.iter().map(|x| x * e.mask));
        }
        let mem = Memory {
            h: Tensor::from_vec(h, (envs.len(), hid), &Device::Cpu)?,
            c: Tensor::from_vec(c, (envs.len(), hid), &Device::Cpu)?,
        };
        let enc = super::Encoded::new(&obs, &missions)?;
        let encoded = secs(encode_t);
        let forward_t = std::time::Instant::now();
        let (logits, values, memory) = net.step_untraced(&enc.codes, &enc.tokens, &mem)?;
        let out = ActAll {
            probs: super::model::probs_host(&logits)?,
            values: values.to_vec1::<f32>()?,
            h: memory.h.to_vec2::<f32>()?,
            c: memory.c.to_vec2::<f32>()?,
        };
        self.times.rollout_encode += encoded;
        self.times.rollout_forward += secs(forward_t);
        Ok(out)
    }

    /// torch-ac's `_get_batches_starting_indexes`.
    fn batch_starts(&mut self) -> Vec<Vec<usize>> {
        let (rec, fpp) = (self.ppo.recurrence, self.ppo.frames_per_proc);
        let n = self.ppo.frames_per_update();
        let mut idx: Vec<usize> = (0..n).step_by(rec).collect();
        idx.shuffle(&mut self.state.batch_rng);
        if self.state.batch_num % 2 == 1 {
            idx.retain(|&i| (i + rec) % fpp != 0);
            for i in &mut idx {
                *i += rec / 2;
            }
        }
        self.state.batch_num += 1;
        idx.chunks(self.ppo.batch_size / rec)
            .map(<[usize]>::to_vec)
            .collect()
    }

    fn optimise(&mut self, ro: &mut Rollout) -> Result<UpdateLog, PolicyError> {
        let net = Net::new(self.model, self.params.tracked());
        let mut log = UpdateLog::default();
        let mut n_batches = 0.0;
        for _ in 0..self.ppo.epochs {
            for starts in self.batch_starts() {
                let per = starts.len().div_ceil(self.ppo.update_threads);
                let parts: Vec<&[usize]> = starts.chunks(per).collect();
                let outs: Vec<(GradStore, ShardOut)> = if let [only] = parts.as_slice() {
                    vec![shard_step(&net, ro, only, &self.ppo)?]
                } else {
                    let ro_ref: &Rollout = ro;
                    let (net, ppo) = (&net, &self.ppo);
                    std::thread::scope(|scope| {
                        let handles: Vec<_> = parts
                            .iter()
                            .map(|part| scope.spawn(move || shard_step(net, ro_ref, part, ppo)))
                            .collect();
                        handles
                            .into_iter()
                            .map(|h| {
                                h.join().map_err(|_| {
                                    PolicyError::Input("an update thread panicked".into())
                                })?
                            })
                            .collect::<Result<Vec<_>, PolicyError>>()
                    })?
                };
                // Each shard's loss is a mean over its frames: its share of the minibatch.
                let shares: Vec<f64> = parts
                    .iter()
                    .map(|p| p.len() as f64 / starts.len() as f64)
                    .collect();
                let (stores, outs): (Vec<GradStore>, Vec<ShardOut>) = outs.into_iter().unzip();
                let opt_t = std::time::Instant::now();
                let mut grads = self.merge_grads(stores, &shares)?;
                for ((part, out), w) in parts.iter().zip(&outs).zip(&shares) {
                    // Refresh the stored memories inside each chunk, as torch-ac does.
                    for (k, (hs, cs)) in out.mems.iter().enumerate() {
                        for (j, &s) in part.iter().enumerate() {
                            ro.h[s + k + 1].clone_from(&hs[j]);
                            ro.c[s + k + 1].clone_from(&cs[j]);
                        }
                    }
                    log.policy_loss += w * out.policy;
                    log.value_loss += w * out.value;
                    log.entropy += w * out.entropy;
                    self.times.add(&out.times);
                }
                let norm = clip_grad_norm(&mut grads, &self.params.vars, self.ppo.max_grad_norm)?;
                self.adam.step(&self.params.vars, &grads)?;
                self.times.optimizer += secs(opt_t);
                log.grad_norm += norm;
                n_batches += 1.0;
            }
        }
        log.policy_loss /= n_batches;
        log.value_loss /= n_batches;
        log.entropy /= n_batches;
        log.grad_norm /= n_batches;
        Ok(log)
    }

    /// The minibatch gradient from its shards' gradients, `Σ share_k · g_k` added in shard
    /// order (one shard: its gradient as it is).
    fn merge_grads(
        &self,
        stores: Vec<GradStore>,
        shares: &[f64],
    ) -> Result<GradStore, PolicyError> {
        let mut stores = stores.into_iter();
        let Some(mut merged) = stores.next() else {
            return Err(PolicyError::Input("empty minibatch".into()));
        };
        let rest: Vec<GradStore> = stores.collect();
        if rest.is_empty() {
            return Ok(merged);
        }
        for v in self.params.vars.values() {
            let mut sum = merged
                .get(v.as_tensor())
                .map(|g| g * shares[0])
                .transpose()?;
            for (grads, &w) in rest.iter().zip(&shares[1..]) {
                if let Some(g) = grads.get(v.as_tensor()) {
                    let g = (g * w)?;
                    sum = Some(match sum {
                        Some(acc) => (acc + g)?,
                        None => g,
                    });
                }
            }
            if let Some(sum) = sum {
                merged.insert(v.as_tensor(), sum);
            }
        }
        Ok(merged)
    }

    /// Serialises the run state (RNG streams, environments, counters) as JSON.
    pub fn state_json(&self) -> Result<String, PolicyError> {
        serde_json::to_string(&self.state)
            .map_err(|e| PolicyError::Input(format!("serialising run state: {e}")))
    }

    /// Restores a run state written by [`Trainer::state_json`], checking every field a later
    /// update relies on; errors name the field (`envs[3].world.agent_pos`, ...).
    pub fn restore_state(&mut self, json: &str) -> Result<(), PolicyError> {
        let st: RunState = serde_json::from_str(json)
            .map_err(|e| PolicyError::Input(format!("reading run state: {e}")))?;
        let bad = |field: String, reason: String| PolicyError::Input(format!("{field}: {reason}"));
        if st.envs.len() != self.ppo.procs {
            return Err(bad(
                "envs".into(),
                format!(
                    "{} environments, the run has --procs {}",
                    st.envs.len(),
                    self.ppo.procs
                ),
            ));
        }
        let hid = self.model.lstm_hidden;
        for (k, e) in st.envs.iter().enumerate() {
            if e.h.len() != hid || e.c.len() != hid {
                return Err(bad(
                    format!("envs[{k}].h"),
                    format!(
                        "memory of length {}/{}, the model has {hid}",
                        e.h.len(),
                        e.c.len()
                    ),
                ));
            }
            if e.h.iter().chain(&e.c).any(|x| !x.is_finite()) {
                return Err(bad(
                    format!("envs[{k}].h"),
                    "holds NaN or infinite values".into(),
                ));
            }
            if e.tokens.is_empty()
                || e.tokens.len() > MAX_STATE_TOKENS
                || e.tokens
                    .iter()
                    .any(|&t| t == 0 || t as usize >= vocab::VOCABULARY.len())
            {
                return Err(bad(
                    format!("envs[{k}].tokens"),
                    format!(
                        "must be 1..={} ids in 1..{}",
                        MAX_STATE_TOKENS,
                        vocab::VOCABULARY.len()
                    ),
                ));
            }
            if e.mask != 0.0 && e.mask != 1.0 {
                return Err(bad(
                    format!("envs[{k}].mask"),
                    format!("{} is not 0 or 1", e.mask),
                ));
            }
            e.world
                .validate()
                .map_err(|err| bad(format!("envs[{k}].world"), err.to_string()))?;
            if e.world.ended() {
                return Err(bad(
                    format!("envs[{k}].world"),
                    "the episode has ended".into(),
                ));
            }
        }
        self.state = st;
        Ok(())
    }

    /// Adam's moments and step as named tensors (for the resume file).
    pub fn optimizer_tensors(&self) -> BTreeMap<String, Tensor> {
        let mut out = BTreeMap::new();
        for (k, (m, v)) in &self.adam.moments {
            out.insert(format!("m.{k}"), m.clone());
            out.insert(format!("v.{k}"), v.clone());
        }
        out
    }

    /// Restores Adam's moments and step.
    pub fn restore_optimizer(
        &mut self,
        tensors: &BTreeMap<String, Tensor>,
        step: u64,
    ) -> Result<(), PolicyError> {
        for (k, (m, v)) in &mut self.adam.moments {
            let (Some(tm), Some(tv)) = (
                tensors.get(&format!("m.{k}")),
                tensors.get(&format!("v.{k}")),
            ) else {
                return Err(PolicyError::Input(format!(
                    "optimizer state lacks the moments of {k}"
                )));
            };
            if tm.dims() != m.dims() || tv.dims() != v.dims() {
                return Err(PolicyError::Input(format!(
                    "optimizer moments of {k} have the wrong shape"
                )));
            }
            *m = tm.clone();
            *v = tv.clone();
        }
        self.adam.step = step;
        Ok(())
    }
}

/// `x ← (x − mean) / (std + 1e-8)`, the population statistics taken in f64.
fn normalize(xs: &mut [f32]) {
    let n = xs.len().max(1) as f64;
    let mean = xs.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
    let var = xs
        .iter()
        .map(|&x| (f64::from(x) - mean).powi(2))
        .sum::<f64>()
        / n;
    let scale = 1.0 / (var.sqrt() + 1e-8);
    for x in xs {
        *x = ((f64::from(*x) - mean) * scale) as f32;
    }
}

struct ActAll {
    probs: Vec<Vec<f32>>,
    values: Vec<f32>,
    h: Vec<Vec<f32>>,
    c: Vec<Vec<f32>>,
}

fn new_slot(level: &LevelConfig, k: u64, hidden: usize) -> Result<EnvSlot, PolicyError> {
    let world = level.generate(TRAIN_SEED_OFFSET + k)?;
    let tokens = vocab::tokenize(&world.mission)?;
    Ok(EnvSlot {
        world,
        tokens,
        h: vec![0.0; hidden],
        c: vec![0.0; hidden],
        mask: 0.0,
        ep_return: 0.0,
        ep_len: 0,
    })
}

/// One chunk step's LSTM `h` and `c` rows on the host, one row per sequence.
type HostMemory = (Vec<Vec<f32>>, Vec<Vec<f32>>);

/// What one shard of a minibatch gives back besides its gradient: its mean losses and the memories
/// it computed at chunk steps 1..rec (for torch-ac's in-place refresh).
struct ShardOut {
    policy: f64,
    value: f64,
    entropy: f64,
    mems: Vec<HostMemory>,
    times: PhaseTimes,
}

/// Forward and backward of the sequences starting at `starts` (read-only on the rollout, so
/// shards can run on threads side by side).
fn shard_step(
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
    let (logits, values, mems) = net.sequence(&codes, &tb, &mem0, &keep)?;
    let mems = mems
        .iter()
        .take(rec - 1)
        .map(|m| Ok((m.h.to_vec2::<f32>()?, m.c.to_vec2::<f32>()?)))
        .collect::<Result<Vec<_>, PolicyError>>()?;
    let actions = Tensor::from_vec(
        rows.iter().map(|&i| ro.actions[i]).collect::<Vec<u32>>(),
        (rows.len(), 1),
        &Device::Cpu,
    )?;
    let losses = ppo_loss(
        &logits,
        &values,
        &actions,
        &gather(&ro.logps)?,
        &gather(&ro.values)?,
        &gather(&ro.advantages)?,
        &gather(&ro.returns)?,
        ppo,
    )?;
    times.update_forward = secs(forward_t);
    let backward_t = std::time::Instant::now();
    let grads = losses.total.backward()?;
    times.update_backward = secs(backward_t);
    let out = ShardOut {
        times,
        policy: f64::from(losses.policy.to_scalar::<f32>()?),
        value: f64::from(losses.value.to_scalar::<f32>()?),
        entropy: f64::from(losses.entropy.to_scalar::<f32>()?),
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
    let logp_all = log_probs(logits)?;
    let entropy = (logp_all.exp()? * &logp_all)?
        .sum(D::Minus1)?
        .mean_all()?
        .neg()?;
    let logp = logp_all.gather(actions, 1)?.squeeze(1)?;
    let ratio = (logp - old_logp)?.exp()?;
    let surr1 = (&ratio * adv)?;
    let surr2 = (ratio.clamp(1.0 - clip, 1.0 + clip)? * adv)?;
    let policy = surr1.minimum(&surr2)?.mean_all()?.neg()?;
    let v_clipped = (old_values + (values - old_values)?.clamp(-clip, clip)?)?;
    let l1 = (values - returns)?.sqr()?;
    let l2 = (v_clipped - returns)?.sqr()?;
    let value = l1.maximum(&l2)?.mean_all()?;
    let total = ((&policy - (&entropy * cfg.entropy_coef)?)? + (&value * cfg.value_loss_coef)?)?;
    Ok(PpoLosses {
        total,
        policy,
        value,
        entropy,
    })
}

/// Converts the optimizer's step count and tensors to safetensors-ready f32 data.
pub fn tensor_to_vec(t: &Tensor) -> Result<Vec<f32>, PolicyError> {
    Ok(t.to_dtype(DType::F32)?.flatten_all()?.to_vec1::<f32>()?)
}
