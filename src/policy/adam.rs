//! Adam (torch's `Adam`, no weight decay) with state that can be saved and restored, so that
//! `train --resume` continues exactly (candle's `AdamW` keeps its moments private).

use std::collections::BTreeMap;

use candle_core::backprop::GradStore;
use candle_core::{Tensor, Var};

use super::error::PolicyError;

/// Adam hyper-parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamConfig {
    /// Learning rate.
    pub lr: f64,
    /// β₁.
    pub beta1: f64,
    /// β₂.
    pub beta2: f64,
    /// ε.
    pub eps: f64,
}

/// Adam's state: first and second moments per parameter and the step count.
#[derive(Debug)]
pub struct Adam {
    /// Hyper-parameters.
    pub cfg: AdamConfig,
    /// Steps taken.
    pub step: u64,
    /// name → (m, v).
    pub moments: BTreeMap<String, (Tensor, Tensor)>,
}

impl Adam {
    /// Fresh state for `vars`.
    pub fn new(cfg: AdamConfig, vars: &BTreeMap<String, Var>) -> Result<Self, PolicyError> {
        let mut moments = BTreeMap::new();
        for (k, v) in vars {
            let z = v.as_tensor().zeros_like()?;
            moments.insert(k.clone(), (z.clone(), z));
        }
        Ok(Self {
            cfg,
            step: 0,
            moments,
        })
    }

    /// One update of every variable that has a gradient.
    pub fn step(
        &mut self,
        vars: &BTreeMap<String, Var>,
        grads: &GradStore,
    ) -> Result<(), PolicyError> {
        self.step += 1;
        let AdamConfig {
            lr,
            beta1,
            beta2,
            eps,
        } = self.cfg;
        let t = self.step as i32;
        let bc1 = 1.0 - beta1.powi(t);
        let bc2 = 1.0 - beta2.powi(t);
        for (k, var) in vars {
            let Some(g) = grads.get(var.as_tensor()) else {
                continue;
            };
            let Some((m, v)) = self.moments.get_mut(k) else {
                continue;
            };
            *m = ((&*m * beta1)? + (g * (1.0 - beta1))?)?;
            *v = ((&*v * beta2)? + (g.sqr()? * (1.0 - beta2))?)?;
            let m_hat = (&*m / bc1)?;
            let v_hat = (&*v / bc2)?;
            let delta = (m_hat / (v_hat.sqrt()? + eps)?)?;
            var.set(&(var.as_tensor() - (delta * lr)?)?)?;
        }
        Ok(())
    }
}

/// Scales gradients so that their global L2 norm is at most `max_norm`; returns the norm
/// before clipping (what torch-ac logs). Sums in name order, so the result is deterministic.
pub fn clip_grad_norm(
    grads: &mut GradStore,
    vars: &BTreeMap<String, Var>,
    max_norm: f64,
) -> Result<f64, PolicyError> {
    let mut sq = 0.0f64;
    for v in vars.values() {
        if let Some(g) = grads.get(v.as_tensor()) {
            sq += f64::from(g.sqr()?.sum_all()?.to_scalar::<f32>()?);
        }
    }
    let norm = sq.sqrt();
    let scale = max_norm / (norm + 1e-6);
    if scale < 1.0 {
        for v in vars.values() {
            if let Some(g) = grads.get(v.as_tensor()) {
                let g = (g * scale)?;
                grads.insert(v.as_tensor(), g);
            }
        }
    }
    Ok(norm)
}
