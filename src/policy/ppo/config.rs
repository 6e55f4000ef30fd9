//! PPO's hyper-parameters, torch-ac's defaults and the checks torch-ac asserts.

use serde::{Deserialize, Serialize};

use crate::policy::error::PolicyError;

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
    /// Threads of the whole update (`train --threads`): the rollout's environments and its
    /// forward passes are split into this many contiguous shards, and each minibatch's forward
    /// and backward pass likewise by sequences; gradients are summed in shard order, so a run
    /// is deterministic for a given count (runs saved before the flag existed used 1; those
    /// saved as `update_threads` split only the update, and now split the rollout too).
    #[serde(default = "one_thread", alias = "update_threads")]
    pub threads: usize,
    /// Rewards are multiplied by this before GAE and the value loss (BabyAI uses 20, which
    /// makes the entropy bonus 20× weaker relative to the returns); logs stay unscaled.
    #[serde(default = "unit_scale")]
    pub reward_scale: f64,
    /// Normalise the advantages of each rollout to mean 0 and standard deviation 1 before the
    /// epochs (over the whole rollout, so the result does not depend on `update_threads`).
    #[serde(default)]
    pub normalize_advantages: bool,
    /// A schedule for the word weights' temperature ([`TemperatureAnneal`]); `None` keeps the
    /// model's. Written only when set, so older run settings read as before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_anneal: Option<TemperatureAnneal>,
    /// From this frame count on, every update leaves the parameters that compute the word
    /// maps as they are ([`crate::policy::params::computes_maps`]): no Adam step, moments
    /// kept, gradients left out of the norm clip. `None` trains every parameter throughout,
    /// as the paper does. Written only when set, so older run settings read as before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub freeze_attention_at: Option<u64>,
    /// Behavioural cloning of minigrid's BabyAI bot (`train --imitate`, BabyAI 1.0's imitation
    /// learning): the rollout takes the bot's actions — demonstrations made on the fly, the
    /// bot told every action — and the policy loss is the cross-entropy of the policy on them
    /// (frames where the bot gave up are left out), with the entropy bonus and the value loss
    /// as PPO's. Written only when set, so older run settings read as before.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub imitate: bool,
    /// With `imitate`: the share of steps on which the policy's own sampled action is taken
    /// while the bot's advice stays the label (DAgger's mixture; the bot, told every action,
    /// replans from wherever the agent went), so the policy learns to recover from its own
    /// mistakes. 0 is pure behavioural cloning. Written only when set.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub imitate_policy_share: f64,
    /// Weight λ of the auxiliary grounding loss (`train --ground-loss`): on every frame where
    /// a scored word names objects in view, `−ln` of the word map's mass on them
    /// ([`crate::env::targets::word_targets`]), and where the clauses waited on have targets in
    /// view, `−ln` of `M`'s mass on those ([`crate::env::targets::pending_targets`]); each
    /// averaged over the pairs that have targets and added to the loss times λ. 0 (the
    /// default) leaves the maps unsupervised, as the paper does. Written only when set.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub ground_loss: f64,
}

#[expect(
    clippy::trivially_copy_pass_by_ref,
    reason = "serde's skip_serializing_if passes a reference"
)]
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// The word temperature annealed over training: `from` until `start` frames, then linearly
/// to `to` at `end` frames, and `to` after. Each update acts and learns at the temperature of
/// the frame count it starts from, and the checkpoint it saves carries that temperature, so
/// a run that reaches `end` with `to` = 1 leaves the paper's model (eq. 5 as written). Kept
/// with the run's settings, so `--resume` continues the schedule exactly.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemperatureAnneal {
    /// The temperature before `start` (the model's at the start of the run).
    pub from: f32,
    /// The temperature from `end` on.
    pub to: f32,
    /// Frames where the temperature starts to move.
    pub start: u64,
    /// Frames where it reaches `to`.
    pub end: u64,
}

impl TemperatureAnneal {
    /// The temperature at `frames`.
    pub fn at(&self, frames: u64) -> f32 {
        if frames <= self.start {
            self.from
        } else if frames >= self.end {
            self.to
        } else {
            let x = (frames - self.start) as f64 / (self.end - self.start) as f64;
            (f64::from(self.from) + (f64::from(self.to) - f64::from(self.from)) * x) as f32
        }
    }

    /// Parses `START:END` (frames) for a schedule from `from` to `to`, naming the flag.
    pub fn parse(s: &str, from: f32, to: f32) -> Result<Self, PolicyError> {
        let bad = || {
            PolicyError::Input(format!(
                "--word-temperature-anneal {s} must be START:END frames with START < END"
            ))
        };
        let (a, b) = s.split_once(':').ok_or_else(bad)?;
        let (start, end) = (
            a.trim().parse::<u64>().map_err(|_| bad())?,
            b.trim().parse::<u64>().map_err(|_| bad())?,
        );
        if start >= end {
            return Err(bad());
        }
        Ok(Self {
            from,
            to,
            start,
            end,
        })
    }
}

/// The largest `--ground-loss` weight accepted: past it the auxiliary term swamps the policy's.
pub const MAX_GROUND_LOSS: f64 = 100.0;

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
            threads: 1,
            reward_scale: 1.0,
            normalize_advantages: false,
            temperature_anneal: None,
            freeze_attention_at: None,
            imitate: false,
            imitate_policy_share: 0.0,
            ground_loss: 0.0,
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
            || self.threads == 0
        {
            return bad(
                "--procs, --frames-per-proc, --epochs, --recurrence and --threads must be positive"
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
            ("--adam-eps", self.adam_eps),
            ("--discount", self.discount),
            ("--gae-lambda", self.gae_lambda),
            ("--clip-eps", self.clip_eps),
            ("--max-grad-norm", self.max_grad_norm),
            ("--reward-scale", self.reward_scale),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{name} {v:?} must be a positive number"));
            }
        }
        // Above 1 the returns and advantages grow without bound (training diverges).
        for (name, v) in [
            ("--discount", self.discount),
            ("--gae-lambda", self.gae_lambda),
        ] {
            if v > 1.0 {
                return bad(format!("{name} {v:?} must be at most 1"));
            }
        }
        // A negative coefficient would reward the loss term it weighs.
        for (name, v) in [
            ("--entropy-coef", self.entropy_coef),
            ("--value-loss-coef", self.value_loss_coef),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} {v:?} must be a number ≥ 0"));
            }
        }
        if !(0.0..=1.0).contains(&self.imitate_policy_share) {
            return bad(format!(
                "--imitate-policy-share {:?} must be between 0 and 1",
                self.imitate_policy_share
            ));
        }
        if self.imitate_policy_share > 0.0 && !self.imitate {
            return bad("--imitate-policy-share needs --imitate".into());
        }
        if !(self.ground_loss.is_finite() && (0.0..=MAX_GROUND_LOSS).contains(&self.ground_loss)) {
            return bad(format!(
                "--ground-loss {:?} must be a number from 0 to {MAX_GROUND_LOSS}",
                self.ground_loss
            ));
        }
        self.validate_anneal()
    }

    /// The schedule's temperatures must be ones the model accepts.
    fn validate_anneal(&self) -> Result<(), PolicyError> {
        if let Some(a) = self.temperature_anneal {
            for t in [a.from, a.to] {
                if !(t.is_finite() && t > 0.0 && t <= crate::policy::WordTemperature::MAX) {
                    return Err(PolicyError::Input(format!(
                        "--word-temperature-anneal: temperature {t:?} must be in (0, {}]",
                        crate::policy::WordTemperature::MAX
                    )));
                }
            }
            if a.start >= a.end {
                return Err(PolicyError::Input(
                    "--word-temperature-anneal: START must be below END".into(),
                ));
            }
        }
        Ok(())
    }

    /// Whether an update that starts at `frames` leaves the map parameters as they are.
    pub fn maps_frozen(&self, frames: u64) -> bool {
        self.freeze_attention_at.is_some_and(|f| frames >= f)
    }

    /// Frames collected per update.
    pub fn frames_per_update(&self) -> usize {
        self.procs * self.frames_per_proc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_anneal_holds_then_moves_linearly_then_holds() {
        let a = TemperatureAnneal::parse("100:300", 3.0, 1.0).unwrap();
        assert_eq!(
            [0, 100, 200, 250, 300, 1000].map(|f| a.at(f)),
            [3.0, 3.0, 2.0, 1.5, 1.0, 1.0]
        );
        for bad in ["300:100", "5:5", "1", "x:2", ":"] {
            let e = TemperatureAnneal::parse(bad, 3.0, 1.0)
                .unwrap_err()
                .to_string();
            assert!(e.contains("--word-temperature-anneal"), "{bad}: {e}");
        }
        let cold = PpoConfig {
            temperature_anneal: Some(TemperatureAnneal { from: 0.0, ..a }),
            ..PpoConfig::default()
        };
        assert!(cold.validate().is_err());
        // Without a schedule the settings serialise as before.
        let json = serde_json::to_string(&PpoConfig::default()).unwrap();
        assert!(!json.contains("anneal"), "{json}");
        assert!(!json.contains("freeze"), "{json}");
    }
}
