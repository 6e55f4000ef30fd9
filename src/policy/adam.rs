//! Adam (torch's `Adam`, no weight decay) with state that can be saved and restored, so that
//! `train --resume` continues exactly (candle's `AdamW` keeps its moments private).

use std::collections::BTreeMap;

use candle_core::backprop::GradStore;
use candle_core::{Device, Tensor, Var};

use super::error::PolicyError;
use super::fused::cpu_f32;

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
        self.step_scaled(vars, grads, None)
    }

    /// [`Self::step`] on the gradients multiplied by `scale` (gradient clipping), computed as
    /// candle's `g * scale` would (`g · scale + 0` in f32) without a tensor of its own.
    pub fn step_scaled(
        &mut self,
        vars: &BTreeMap<String, Var>,
        grads: &GradStore,
        scale: Option<f64>,
    ) -> Result<(), PolicyError> {
        self.step += 1;
        // The update runs as one host loop per parameter: as candle ops it was ten full-size
        // temporaries per parameter and a tenth of the training time (issue #16).
        let update = AdamUpdate::new(&self.cfg, self.step);
        let scale = scale.map(|s| s as f32);
        for (k, var) in vars {
            let Some(g) = grads.get(var.as_tensor()) else {
                continue;
            };
            let Some((m, v)) = self.moments.get_mut(k) else {
                continue;
            };
            let shape = var.as_tensor().shape().clone();
            let g = g.contiguous()?;
            // Copies of the operands (plain memcpys), then one in-place loop that the compiler
            // vectorises; the scale is a separate instantiation, not a branch in the loop.
            let (pn, mn, vn) = {
                let (gs, gl) = g.storage_and_layout();
                let (ps, pl) = var.as_tensor().storage_and_layout();
                let (ms, ml) = m.storage_and_layout();
                let (vs, vl) = v.storage_and_layout();
                let g = cpu_f32(&gs, gl, "adam: gradient")?;
                if g.len() != shape.elem_count() {
                    return Err(PolicyError::Input(format!(
                        "adam: gradient of {k} has {} values, not {}",
                        g.len(),
                        shape.elem_count()
                    )));
                }
                let mut out = (
                    cpu_f32(&ps, pl, "adam: parameter")?.to_vec(),
                    cpu_f32(&ms, ml, "adam: first moment")?.to_vec(),
                    cpu_f32(&vs, vl, "adam: second moment")?.to_vec(),
                );
                match scale {
                    Some(s) => update.run(&mut out, g, |g| g * s + 0.0),
                    None => update.run(&mut out, g, |g| g),
                }
                out
            };
            *m = Tensor::from_vec(mn, shape.clone(), &Device::Cpu)?;
            *v = Tensor::from_vec(vn, shape.clone(), &Device::Cpu)?;
            var.set(&Tensor::from_vec(pn, shape, &Device::Cpu)?)?;
        }
        Ok(())
    }
}

/// One Adam step's constants in f32, bias corrections of step `t` included.
#[derive(Clone, Copy)]
struct AdamUpdate {
    b1: f32,
    b2: f32,
    bc1: f32,
    bc2: f32,
    lr: f32,
    eps: f32,
}

impl AdamUpdate {
    fn new(cfg: &AdamConfig, t: u64) -> Self {
        let t = t as i32;
        Self {
            b1: cfg.beta1 as f32,
            b2: cfg.beta2 as f32,
            bc1: (1.0 - cfg.beta1.powi(t)) as f32,
            bc2: (1.0 - cfg.beta2.powi(t)) as f32,
            lr: cfg.lr as f32,
            eps: cfg.eps as f32,
        }
    }

    /// `(p, m, v)` updated in place from the gradient `grad(g)` of every element.
    #[inline]
    fn run(
        &self,
        (p, m, v): &mut (Vec<f32>, Vec<f32>, Vec<f32>),
        g: &[f32],
        grad: impl Fn(f32) -> f32,
    ) {
        let Self {
            b1,
            b2,
            bc1,
            bc2,
            lr,
            eps,
        } = *self;
        for (((p, m), v), &g) in p.iter_mut().zip(m.iter_mut()).zip(v.iter_mut()).zip(g) {
            let g = grad(g);
            *m = b1 * *m + (1.0 - b1) * g;
            *v = b2 * *v + (1.0 - b2) * g * g;
            *p -= lr * ((*m / bc1) / ((*v / bc2).sqrt() + eps));
        }
    }
}

/// The minibatch gradient from its shards' gradients, `Σ share_k · g_k` added in shard
/// order (one shard: its gradient as it is).
pub fn merge_shards(
    vars: &BTreeMap<String, Var>,
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
    // One host pass per parameter with candle's arithmetic: `g * w` is its affine
    // `g · w + 0` in f32, and the terms are added in shard order, as tensors they were.
    let shares: Vec<f32> = shares.iter().map(|&w| w as f32).collect();
    for v in vars.values() {
        let terms: Vec<(Tensor, f32)> = std::iter::once(&merged)
            .chain(&rest)
            .zip(&shares)
            .filter_map(|(grads, &w)| grads.get(v.as_tensor()).map(|g| (g.clone(), w)))
            .map(|(g, w)| Ok((g.contiguous()?, w)))
            .collect::<Result<_, PolicyError>>()?;
        let Some(shape) = terms.first().map(|(g, _)| g.shape().clone()) else {
            continue;
        };
        let mut sum = vec![0f32; shape.elem_count()];
        for (k, (g, w)) in terms.iter().enumerate() {
            let (gs, gl) = g.storage_and_layout();
            let g = cpu_f32(&gs, gl, "shard gradient")?;
            if g.len() != sum.len() {
                return Err(PolicyError::Input("shard gradients differ in shape".into()));
            }
            if k == 0 {
                sum.iter_mut().zip(g).for_each(|(s, &g)| *s = g * w + 0.0);
            } else {
                sum.iter_mut().zip(g).for_each(|(s, &g)| *s += g * w + 0.0);
            }
        }
        merged.insert(v.as_tensor(), Tensor::from_vec(sum, shape, &Device::Cpu)?);
    }
    Ok(merged)
}

/// The global gradient norm `‖g‖₂` over `vars` (each parameter's sum of squares by candle,
/// added in f64 in name order) and the factor that clips it to `max_norm` (torch's
/// `clip_grad_norm_`: `max_norm / (‖g‖ + 1e-6)` where that is below 1).
pub fn grad_norm(
    grads: &GradStore,
    vars: &BTreeMap<String, Var>,
    max_norm: f64,
) -> Result<(f64, Option<f64>), PolicyError> {
    let mut sq = 0.0f64;
    for v in vars.values() {
        if let Some(g) = grads.get(v.as_tensor()) {
            sq += f64::from(g.sqr()?.sum_all()?.to_scalar::<f32>()?);
        }
    }
    let norm = sq.sqrt();
    let scale = max_norm / (norm + 1e-6);
    Ok((norm, (scale < 1.0).then_some(scale)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_steps_follow_torchs_formula() {
        let x0 = [1.0f64, -2.0, 0.5, 3.0];
        let gs = [[0.1f64, -0.3, 0.0, 2.0], [-0.2, -0.1, 0.05, 1.0]];
        let var = Var::from_tensor(
            &Tensor::from_vec(x0.map(|x| x as f32).to_vec(), (2, 2), &Device::Cpu).unwrap(),
        )
        .unwrap();
        let vars = BTreeMap::from([("p".to_owned(), var.clone())]);
        let cfg = AdamConfig {
            lr: 0.01,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
        };
        let mut adam = Adam::new(cfg, &vars).unwrap();
        let (mut x, mut m, mut v) = (x0, [0f64; 4], [0f64; 4]);
        for (t, g) in gs.iter().enumerate() {
            let gt = Tensor::from_vec(g.map(|x| x as f32).to_vec(), (2, 2), &Device::Cpu).unwrap();
            // d/dp Σ p·g = g.
            let store = (var.as_tensor() * gt)
                .unwrap()
                .sum_all()
                .unwrap()
                .backward()
                .unwrap();
            adam.step(&vars, &store).unwrap();
            let t = t as i32 + 1;
            for i in 0..4 {
                m[i] = 0.9 * m[i] + 0.1 * g[i];
                v[i] = 0.999 * v[i] + 0.001 * g[i] * g[i];
                let (mh, vh) = (
                    m[i] / (1.0 - 0.9f64.powi(t)),
                    v[i] / (1.0 - 0.999f64.powi(t)),
                );
                x[i] -= 0.01 * mh / (vh.sqrt() + 1e-8);
            }
        }
        let got: Vec<f32> = var.as_tensor().flatten_all().unwrap().to_vec1().unwrap();
        for (a, b) in got.iter().zip(&x) {
            assert!((f64::from(*a) - b).abs() < 1e-6, "{a} vs {b}");
        }
        // The parameter with a zero first gradient still moved on the second step.
        assert!((f64::from(got[2]) - 0.5).abs() > 1e-3);
        assert_eq!(adam.step, 2);
    }
}
