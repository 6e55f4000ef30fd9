//! Recurrent PPO as torch-ac does it: P environments stepped together for T frames, GAE,
//! clipped policy and value losses, an entropy bonus, BPTT over chunks of `recurrence` frames
//! with episode masks (stored memories refreshed during the epochs), global grad-norm
//! clipping, Adam.
//!
//! The rollout ([`rollout`], with [`gae`]) and the update ([`update`], losses in [`loss`]) are
//! methods of [`Trainer`] in modules of their own.
//!
//! Buffers are proc-major (frame `i = p·T + t`), as torch-ac's; minibatches are t-major inside
//! (row = k·n + j for step k of sequence j). Training level seeds start at
//! [`TRAIN_SEED_OFFSET`], so evaluation seeds (small integers) are never trained on.

pub mod adam;
mod config;
mod gae;
pub mod grads;
mod ground;
mod loss;
mod missions;
mod mix;
mod rollout;
mod state;
mod teacher;
mod update;
mod workers;

use rand::SeedableRng as _;
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use super::ModelConfig;
use super::error::PolicyError;
use super::params::Params;
use crate::env::level::LevelConfig;
use crate::env::vocab;
use crate::env::world::World;
use adam::{Adam, AdamConfig};

pub use config::{PpoConfig, TemperatureAnneal};
pub use loss::{PpoLosses, ppo_loss, tensor_to_vec};
pub use mix::{LevelMix, MixEntry};
pub use teacher::{TeacherSpec, teacher_of};

pub use crate::env::seeds::TRAIN_SEED_OFFSET;

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
    /// minigrid's bot beside the episode (`--imitate`): its demonstration's next action.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    expert: Option<crate::bot::Expert>,
    /// The index of the episode's level in the mix (0 in run states written before).
    #[serde(default, skip_serializing_if = "is_zero")]
    entry: usize,
    /// `--teacher`: the teacher's memory after the last step (empty where none teaches).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    teacher_h: Vec<f32>,
    /// The teacher's cell state.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    teacher_c: Vec<f32>,
}

#[allow(
    clippy::trivially_copy_pass_by_ref,
    reason = "serde's skip_serializing_if passes a reference"
)]
fn is_zero(x: &usize) -> bool {
    *x == 0
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
    /// The distinct missions the rollouts have met, in the order the next rollout computes
    /// their inputs as one batch. Saved because a matrix product's rounding can depend on
    /// the batch it runs in: a resumed run that met them again one by one drifted from the
    /// uninterrupted run by 1e-8 after one update. Empty in run states written before.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    missions: Vec<Vec<u32>>,
    /// The `--ground-loss` weight of the run this one was started from with `--init` (or of
    /// its own ancestors), so that a checkpoint names supervision its maps inherited.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parent_ground_loss: Option<f64>,
    /// `--teacher`: the policies imitation learns from, loaded again on a resume.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub teachers: Vec<TeacherSpec>,
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
    /// Mean unweighted grounding term of `--ground-loss` (0 without it): printed, not in
    /// `log.csv`, whose columns stay the paper's.
    #[serde(default)]
    pub ground_loss: f64,
}

/// A PPO trainer over one level.
pub struct Trainer {
    /// Network sizes.
    pub model: ModelConfig,
    /// The levels trained on (one, or a weighted mix).
    pub levels: LevelMix,
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
    /// `--teacher`'s networks (not saved: the run state names them).
    teachers: Option<teacher::Teachers>,
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

impl Trainer {
    /// A fresh run: weights from `seed`, P environments on the first training seeds.
    pub fn new(
        model: ModelConfig,
        levels: impl Into<LevelMix>,
        ppo: PpoConfig,
        params: Params,
        seed: u64,
    ) -> Result<Self, PolicyError> {
        ppo.validate()?;
        let levels = levels.into();
        for e in levels.entries() {
            e.level.validate()?;
        }
        if ppo.freeze_attention_at.is_some() && !model.has_attention() {
            return Err(PolicyError::Input(
                "--freeze-attention-at: a baseline has no word maps to freeze; use --model attention"
                    .into(),
            ));
        }
        if ppo.ground_loss > 0.0 && !model.has_attention() {
            return Err(PolicyError::Input(
                "--ground-loss: a baseline has no word maps to supervise; use --model attention"
                    .into(),
            ));
        }
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
            envs.push(new_slot(
                &levels,
                &mut next_seed,
                model.lstm_hidden,
                &|_| ppo.imitate,
            )?);
        }
        Ok(Self {
            model,
            levels,
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
                missions: Vec::new(),
                parent_ground_loss: None,
                teachers: Vec::new(),
            },
            times: PhaseTimes::default(),
            missions: missions::MissionCache::default(),
            teachers: None,
        })
    }

    /// A new run that starts from trained weights (`train --init`): fresh Adam moments and
    /// RNG streams, but the frame and update counters continue from `frames` / `updates`, so
    /// budgets and logs count the parent run's frames too. Level seeds start past any the
    /// parent can have used: it started at most `frames + procs` episodes.
    pub fn warm_start(
        model: ModelConfig,
        levels: impl Into<LevelMix>,
        ppo: PpoConfig,
        params: Params,
        seed: u64,
        frames: u64,
        updates: u64,
    ) -> Result<Self, PolicyError> {
        let mut trainer = Self::new(model, levels, ppo, params, seed)?;
        let mut next_seed = frames + WARM_START_SEED_GAP;
        for slot in &mut trainer.state.envs {
            *slot = new_slot(&trainer.levels, &mut next_seed, model.lstm_hidden, &|_| {
                ppo.imitate
            })?;
        }
        trainer.state.next_seed = next_seed;
        trainer.state.frames = frames;
        trainer.state.updates = updates;
        Ok(trainer)
    }

    /// The level a checkpoint of this run names (the first of a mix).
    pub fn level(&self) -> LevelConfig {
        self.levels.first()
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
            ("grounding loss", log.ground_loss),
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
}

/// A fresh episode on the next training seed, `next_seed` advanced past it (and past any
/// seed minigrid cannot generate: it loops forever there, so no such level exists), with the
/// bot beside it where `bot` says so of its mix entry.
fn new_slot(
    levels: &LevelMix,
    next_seed: &mut u64,
    hidden: usize,
    bot: &dyn Fn(usize) -> bool,
) -> Result<EnvSlot, PolicyError> {
    let (entry, level, seed, world) = loop {
        let k = *next_seed;
        *next_seed += 1;
        let entry = levels.pick_entry(k);
        let level = levels.entries()[entry].level;
        let seed = TRAIN_SEED_OFFSET + k;
        match level.generate(seed) {
            Err(crate::env::EnvError::GenerationHangs { .. }) => {}
            world => break (entry, level, seed, world?),
        }
    };
    let tokens = vocab::tokenize_on_level(&world.mission, || format!("{level} seed {seed}"))?;
    Ok(EnvSlot {
        expert: bot(entry).then(|| crate::bot::Expert::new(&world)),
        entry,
        teacher_h: Vec::new(),
        teacher_c: Vec::new(),
        world,
        tokens,
        h: vec![0.0; hidden],
        c: vec![0.0; hidden],
        mask: 0.0,
        ep_return: 0.0,
        ep_len: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A training seed minigrid loops forever on (SynthS5R2's 2^32 + 14829, met by a real
    /// run) is passed over: the slot takes the next seed, and the counter moves past both.
    #[test]
    fn training_skips_seeds_minigrid_cannot_generate() {
        let id = crate::env::level::LevelId::parse("BabyAI-SynthS5R2-v0").unwrap();
        let levels = LevelMix::from(LevelConfig::babyai(id, false));
        let mut next = 14_829;
        assert!(matches!(
            levels.first().generate(TRAIN_SEED_OFFSET + next),
            Err(crate::env::EnvError::GenerationHangs { .. })
        ));
        let slot = new_slot(&levels, &mut next, 8, &|_| true).unwrap();
        assert_eq!(next, 14_831);
        let world = levels.first().generate(TRAIN_SEED_OFFSET + 14_830).unwrap();
        assert_eq!(slot.world.mission, world.mission);
        assert!(slot.expert.is_some());
    }
}
