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
            ("--adam-eps", self.adam_eps),
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
        // Above 1 the returns and advantages grow without bound (training diverges).
        for (name, v) in [
            ("--discount", self.discount),
            ("--gae-lambda", self.gae_lambda),
        ] {
            if v > 1.0 {
                return bad(format!("{name} {v} must be at most 1"));
            }
        }
        // A negative coefficient would reward the loss term it weighs.
        for (name, v) in [
            ("--entropy-coef", self.entropy_coef),
            ("--value-loss-coef", self.value_loss_coef),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{name} {v} must be a number ≥ 0"));
            }
        }
        Ok(())
    }

    /// Frames collected per update.
    pub fn frames_per_update(&self) -> usize {
        self.procs * self.frames_per_proc
    }
}
