//! Recurrent PPO as torch-ac does it: P environments stepped together for T frames, GAE,
//! clipped policy and value losses, an entropy bonus, BPTT over chunks of `recurrence` frames
//! with episode masks (stored memories refreshed during the epochs), global grad-norm
//! clipping, Adam.
//!
//! Buffers are proc-major (frame `i = p·T + t`), as torch-ac's; minibatches are t-major inside
//! (row = k·n + j for step k of sequence j). Training level seeds start at
//! [`TRAIN_SEED_OFFSET`], so evaluation seeds (small integers) are never trained on.

mod config;
mod loss;
mod missions;
mod state;

use candle_core::backprop::GradStore;
use candle_core::{Device, Tensor};
use rand::seq::SliceRandom as _;
use rand::{Rng as _, SeedableRng as _};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use super::ModelConfig;
use super::adam::{Adam, AdamConfig};
use super::error::PolicyError;
use super::grads::{clip_factor, with_minibatch_grads};
use super::model::{Memory, Net};
use super::params::Params;
use crate::env::level::LevelConfig;
use crate::env::view::Observation;
use crate::env::vocab;
use crate::env::world::{Action, World};

pub use config::{PpoConfig, TemperatureAnneal};
pub use loss::{PpoLosses, ppo_loss, tensor_to_vec};
use loss::{ShardOut, shard_step};

/// Level seeds used in training are `TRAIN_SEED_OFFSET + k`.
pub const TRAIN_SEED_OFFSET: u64 = 1 << 32;

/// A warm-started run's level seeds start this far past its parent's frame count, which is
/// more than any parent's number of environments.
const WARM_START_SEED_GAP: u64 = 1 << 16;

/// The longest mission a run state may hold (BabyAI's local missions have at most 9 words).
const MAX_STATE_TOKENS: usize = 64;

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
    /// The missions the rollouts have met, kept across updates (not saved: it only decides
    /// which rows are computed together, not their values).
    missions: missions::MissionCache,
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
            missions: missions::MissionCache::default(),
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
        if let Some(a) = self.ppo.temperature_anneal {
            self.model.word_temperature = crate::policy::WordTemperature(a.at(self.state.frames));
        }
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
        let mut missions = std::mem::take(&mut self.missions);
        missions.renew();
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
            let out = self.act_all(&net, &mut missions)?;
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
        let last = self.act_all(&net, &mut missions)?;
        self.missions = missions;
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
    fn act_all(
        &mut self,
        net: &Net,
        cache: &mut missions::MissionCache,
    ) -> Result<ActAll, PolicyError> {
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
        let codes = super::obs::CellCodes::new(&obs);
        let encoded = secs(encode_t);
        let forward_t = std::time::Instant::now();
        let mission = cache.inputs(net, &missions)?;
        let (logits, values, memory) = net.step_untraced(&codes, &mission, &mem)?;
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
                let (adam, threads) = (&mut self.adam, self.ppo.update_threads);
                let norm =
                    with_minibatch_grads(&self.params.vars, &stores, &shares, threads, |grads| {
                        let (norm, clip) = clip_factor(grads, self.ppo.max_grad_norm);
                        adam.step_host(grads, clip, threads)?;
                        Ok(norm)
                    })?;
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
