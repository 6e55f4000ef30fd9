//! Adam (torch's `Adam`, no weight decay) with state that can be saved and restored, so that
//! `train --resume` continues exactly (candle's `AdamW` keeps its moments private).

use std::collections::BTreeMap;

use candle_core::backprop::GradStore;
use candle_core::{CpuStorage, Storage, Var};

use super::grads::{Grad, ParamGrad, on_threads, with_minibatch_grads};
use crate::policy::error::PolicyError;

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
    /// name → moments, in the parameter's row-major order.
    pub moments: BTreeMap<String, Moments>,
}

/// One parameter's first and second moments, kept on the host: a step updates them in place
/// instead of copying them out of tensors and back.
#[derive(Clone, Debug, PartialEq)]
pub struct Moments {
    /// First moment.
    pub m: Vec<f32>,
    /// Second moment.
    pub v: Vec<f32>,
}

impl Adam {
    /// Fresh state for `vars`.
    pub fn new(cfg: AdamConfig, vars: &BTreeMap<String, Var>) -> Result<Self, PolicyError> {
        let moments = vars
            .iter()
            .map(|(k, v)| {
                let n = v.as_tensor().elem_count();
                (
                    k.clone(),
                    Moments {
                        m: vec![0.0; n],
                        v: vec![0.0; n],
                    },
                )
            })
            .collect();
        Ok(Self {
            cfg,
            step: 0,
            moments,
        })
    }

    /// One update of every variable that has a gradient in `grads`.
    pub fn step(
        &mut self,
        vars: &BTreeMap<String, Var>,
        grads: &GradStore,
    ) -> Result<(), PolicyError> {
        with_minibatch_grads(vars, std::slice::from_ref(grads), &[1.0], |g| {
            self.step_host(g, None, 1)
        })
    }

    /// One update from gradients on the host ([`super::grads::with_minibatch_grads`]),
    /// multiplied by `scale` (gradient clipping) as candle's `g * scale` would (`g · scale +
    /// 0` in f32) without a tensor of its own, with every parameter's elements split across
    /// `threads` (each element's arithmetic is the same on any thread, so the result does not
    /// depend on the count).
    pub fn step_host(
        &mut self,
        grads: &[ParamGrad<'_>],
        scale: Option<f64>,
        threads: usize,
    ) -> Result<(), PolicyError> {
        self.step += 1;
        // One host loop per parameter: as candle ops it was ten full-size temporaries per
        // parameter and a tenth of the training time (issue #16).
        let update = AdamUpdate::new(&self.cfg, self.step);
        let scale = scale.map(|s| s as f32);
        // The moments of each parameter, walked alongside (both in name order).
        let mut moments = Vec::with_capacity(grads.len());
        let mut rest = self.moments.iter_mut();
        for (name, var, g) in grads {
            let mo = rest
                .find(|(k, _)| k.as_str() == *name)
                .map(|(_, mo)| mo)
                .ok_or_else(|| PolicyError::Input(format!("adam: no moments for {name}")))?;
            let n = var.as_tensor().elem_count();
            if g.len() != n || mo.m.len() != n || mo.v.len() != n {
                return Err(PolicyError::Input(format!(
                    "adam: gradient or moments of {name} do not have its {n} values"
                )));
            }
            moments.push(mo);
        }
        // Every parameter written in place (as `Var::set` would), cut into `threads` ranges;
        // thread t updates the t-th range of each.
        let mut storages = grads
            .iter()
            .map(|(_, var, _)| var.write_storage())
            .collect::<Result<Vec<_>, _>>()?;
        let threads = threads.max(1);
        let mut jobs: Vec<Vec<Job<'_>>> = (0..threads).map(|_| Vec::new()).collect();
        for (((storage, layout), (name, _, g)), mo) in
            storages.iter_mut().zip(grads).zip(&mut moments)
        {
            let (Storage::Cpu(CpuStorage::F32(values)), Some((lo, hi))) =
                (&mut **storage, layout.contiguous_offsets())
            else {
                return Err(PolicyError::Input(format!(
                    "adam: {name} is not a contiguous f32 tensor on the CPU"
                )));
            };
            let p = &mut values[lo..hi];
            let per = p.len().div_ceil(threads).max(1);
            let parts = p
                .chunks_mut(per)
                .zip(mo.m.chunks_mut(per))
                .zip(mo.v.chunks_mut(per));
            for (t, ((p, m), v)) in parts.enumerate() {
                let from = t * per;
                let g = (g, from..from + p.len());
                jobs[t].push(Job { p, g, m, v });
            }
        }
        let run = |jobs: Vec<Job<'_>>| {
            for job in jobs {
                update.run(job, scale);
            }
        };
        on_threads(jobs, run)
    }
}

/// One thread's share of one parameter: its elements' parameter values (updated in place),
/// gradients (the parameter's and the range) and moments (updated in place).
struct Job<'a> {
    p: &'a mut [f32],
    g: (&'a Grad<'a>, std::ops::Range<usize>),
    m: &'a mut [f32],
    v: &'a mut [f32],
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

    /// A job's new parameters and moments from the gradient of every element, each first
    /// multiplied by the clip factor `scale` where there is one.
    #[inline]
    fn run(&self, job: Job<'_>, scale: Option<f32>) {
        let Job { p, g, m, v } = job;
        let c = [self.b1, self.b2, self.bc1, self.bc2, self.lr, self.eps];
        let (grad, range) = g;
        grad.for_each_chunk(range, |off, g| {
            let r = off..off + g.len();
            adam_elements(
                &mut p[r.clone()],
                g,
                &mut m[r.clone()],
                &mut v[r],
                c,
                scale.unwrap_or(1.0),
                scale.is_some(),
            );
        });
    }
}

crate::multiversion! {
    /// Adam on a range of elements (compiled for the vector unit the CPU has: the same
    /// operations in the same order on every clone, so the same bits). `c` holds β₁, β₂,
    /// the two bias corrections, the learning rate and ε; with `scaled`, each gradient is
    /// first `g · scale + 0` as candle's `g * scale` computes it.
    fn adam_elements(
        p: &mut [f32],
        g: &[f32],
        m: &mut [f32],
        v: &mut [f32],
        c: [f32; 6],
        scale: f32,
        scaled: bool,
    ) {
        let [b1, b2, bc1, bc2, lr, eps] = c;
        for (((p, m), v), &g) in p.iter_mut().zip(m).zip(v).zip(g) {
            let g = if scaled { g * scale + 0.0 } else { g };
            *m = b1 * *m + (1.0 - b1) * g;
            *v = b2 * *v + (1.0 - b2) * g * g;
            *p -= lr * ((*m / bc1) / ((*v / bc2).sqrt() + eps));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::{Device, Tensor};

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

    #[test]
    fn threads_split_elements_without_changing_a_bit() {
        // 1,001 elements: uneven ranges for 2 and 3 threads, and a bias-sized parameter.
        let run = |threads: usize| {
            let vars: BTreeMap<String, Var> = [("a", 1001usize), ("b", 3)]
                .into_iter()
                .map(|(k, n)| {
                    let v: Vec<f32> = (0..n).map(|i| (i as f32 * 0.37).sin()).collect();
                    let t = Tensor::from_vec(v, n, &Device::Cpu).unwrap();
                    (k.to_owned(), Var::from_tensor(&t).unwrap())
                })
                .collect();
            let mut adam = Adam::new(
                AdamConfig {
                    lr: 0.003,
                    beta1: 0.9,
                    beta2: 0.999,
                    eps: 1e-5,
                },
                &vars,
            )
            .unwrap();
            for step in 0..3 {
                let loss = vars
                    .values()
                    .map(|v| {
                        let t = v.as_tensor();
                        (t.sqr().unwrap() * (step as f64 + 1.0))
                            .unwrap()
                            .sum_all()
                            .unwrap()
                    })
                    .reduce(|a, b| (a + b).unwrap())
                    .unwrap();
                let grads = loss.backward().unwrap();
                with_minibatch_grads(&vars, std::slice::from_ref(&grads), &[1.0], |g| {
                    adam.step_host(g, (step == 1).then_some(0.5), threads)
                })
                .unwrap();
            }
            let bits = |t: &Tensor| -> Vec<u32> {
                let v: Vec<f32> = t.to_vec1().unwrap();
                v.into_iter().map(f32::to_bits).collect()
            };
            let params: Vec<Vec<u32>> = vars.values().map(|v| bits(v.as_tensor())).collect();
            (params, adam.moments)
        };
        let one = run(1);
        assert_eq!(run(2), one);
        assert_eq!(run(3), one);
    }
}
