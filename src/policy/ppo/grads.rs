//! A minibatch's gradient on the host, for the optimizer: its shards' gradients merged, and
//! the global norm with torch's clip factor. One pass over host buffers each, where candle
//! ops allocated a tensor per parameter for the merge and another for the norm's squares,
//! while the second update thread waited (issue #16).

use std::collections::BTreeMap;

use candle_core::backprop::GradStore;
use candle_core::{Tensor, Var};

use crate::policy::error::PolicyError;
use crate::policy::kernels::cpu_f32;

/// One parameter's gradient: its name, its variable and the values in row-major order.
pub type ParamGrad<'a> = (&'a str, &'a Var, &'a [f32]);

/// One shard's term of a parameter's gradient: the values (or a range of them) and the
/// shard's share of the minibatch.
type Term<'a> = (&'a [f32], f32);

/// One parameter's name, variable and contiguous gradient terms (tensor, share).
type ParamTerms<'a> = (&'a str, &'a Var, Vec<(Tensor, f32)>);

/// A range of one parameter's merged gradient and the shards' terms over that range.
type MergeJob<'a> = (&'a mut [f32], Vec<Term<'a>>);

/// Calls `f` with the minibatch gradient of every parameter of `vars` that has one (in name
/// order): `Σ share_k · g_k` over the shards' stores, each term computed as candle's
/// `g * share` (`g · share + 0` in f32) and added in shard order; one store is taken as it
/// is. The merge splits every parameter's elements across `threads`; each element's sum is
/// the same on any thread.
pub fn with_minibatch_grads<R>(
    vars: &BTreeMap<String, Var>,
    stores: &[GradStore],
    shares: &[f64],
    threads: usize,
    f: impl FnOnce(&[ParamGrad<'_>]) -> Result<R, PolicyError>,
) -> Result<R, PolicyError> {
    if stores.is_empty() || stores.len() != shares.len() {
        return Err(PolicyError::Input(format!(
            "{} gradient stores for {} shares",
            stores.len(),
            shares.len()
        )));
    }
    // Each parameter's terms, contiguous (candle hands most weight gradients transposed).
    let mut terms: Vec<ParamTerms<'_>> = Vec::new();
    for (name, var) in vars {
        let ts = stores
            .iter()
            .zip(shares)
            .filter_map(|(s, &w)| s.get(var.as_tensor()).map(|g| (g, w as f32)))
            .map(|(g, w)| Ok((g.contiguous()?, w)))
            .collect::<Result<Vec<_>, PolicyError>>()?;
        if !ts.is_empty() {
            terms.push((name, var, ts));
        }
    }
    let guards = terms
        .iter()
        .map(|(_, _, ts)| ts.iter().map(|(g, _)| g.storage_and_layout()).collect())
        .collect::<Vec<Vec<_>>>();
    let mut slices: Vec<Vec<Term<'_>>> = Vec::with_capacity(terms.len());
    for ((name, var, ts), gs) in terms.iter().zip(&guards) {
        let n = var.as_tensor().elem_count();
        let mut s = Vec::with_capacity(gs.len());
        for ((g, l), (_, w)) in gs.iter().zip(ts) {
            let g = cpu_f32(g, l, "gradient")?;
            if g.len() != n {
                return Err(PolicyError::Input(format!(
                    "the gradient of {name} has {} values, not {n}",
                    g.len()
                )));
            }
            s.push((g, *w));
        }
        slices.push(s);
    }
    if stores.len() == 1 {
        let grads: Vec<ParamGrad<'_>> = terms
            .iter()
            .zip(&slices)
            .map(|((name, var, _), s)| (*name, *var, s[0].0))
            .collect();
        return f(&grads);
    }
    let mut merged: Vec<Vec<f32>> = slices.iter().map(|s| vec![0f32; s[0].0.len()]).collect();
    let threads = threads.max(1);
    // Thread t merges the t-th range of every parameter.
    let mut jobs: Vec<Vec<MergeJob<'_>>> = (0..threads).map(|_| Vec::new()).collect();
    for (out, s) in merged.iter_mut().zip(&slices) {
        let per = out.len().div_ceil(threads).max(1);
        for (t, out) in out.chunks_mut(per).enumerate() {
            let lo = t * per;
            let parts = s
                .iter()
                .map(|&(g, w)| (&g[lo..lo + out.len()], w))
                .collect();
            jobs[t].push((out, parts));
        }
    }
    let run = |jobs: Vec<MergeJob<'_>>| {
        for (out, parts) in jobs {
            for (k, (g, w)) in parts.into_iter().enumerate() {
                add_term(out, g, w, k == 0);
            }
        }
    };
    on_threads(jobs, run)?;
    let grads: Vec<ParamGrad<'_>> = terms
        .iter()
        .zip(&merged)
        .map(|((name, var, _), g)| (*name, *var, g.as_slice()))
        .collect();
    f(&grads)
}

crate::multiversion! {
    /// `out ← g·w + 0` (`first`) or `out ← out + (g·w + 0)`: one shard's term of a merged
    /// gradient, as candle's `g * w` and `+` compute it (compiled for the CPU's vector unit;
    /// the same bits on every clone).
    fn add_term(out: &mut [f32], g: &[f32], w: f32, first: bool) {
        if first {
            out.iter_mut().zip(g).for_each(|(s, &g)| *s = g * w + 0.0);
        } else {
            out.iter_mut().zip(g).for_each(|(s, &g)| *s += g * w + 0.0);
        }
    }
}

crate::multiversion! {
    /// [`sum_squares`] compiled for the CPU's vector unit: its accumulators are explicit,
    /// so every clone adds in the same order.
    fn sum_squares_simd(x: &[f32]) -> f32 {
        sum_squares(x)
    }
}

/// Runs each thread's list of jobs on a thread of its own, the first on the calling thread
/// and the others on the training pool's warm threads.
pub(super) fn on_threads<J: Send>(
    jobs: Vec<Vec<J>>,
    run: impl Fn(Vec<J>) + Sync,
) -> Result<(), PolicyError> {
    let run = &run;
    let jobs: Vec<_> = jobs
        .into_iter()
        .map(|list| {
            move || -> Result<(), PolicyError> {
                run(list);
                Ok(())
            }
        })
        .collect();
    super::workers::run_all(jobs).map(drop)
}

/// The global gradient norm `‖g‖₂` (each parameter's sum of squares in f32, added in f64 in
/// name order) and the factor that clips it to `max_norm` (torch's `clip_grad_norm_`:
/// `max_norm / (‖g‖ + 1e-6)` where that is below 1).
pub fn clip_factor(grads: &[ParamGrad<'_>], max_norm: f64) -> (f64, Option<f64>) {
    let sq: f64 = grads
        .iter()
        .map(|(_, _, g)| f64::from(sum_squares_simd(g)))
        .sum();
    let norm = sq.sqrt();
    let scale = max_norm / (norm + 1e-6);
    (norm, (scale < 1.0).then_some(scale))
}

/// `Σ x²` in f32, added as candle's `x.sqr()?.sum_all()` adds it on a CPU with AVX2 (its
/// `vec_sum`: four 8-lane accumulators over blocks of 32 values, reduced pairwise, then the
/// remaining values in order), so that the clip factor keeps the bits it had as candle ops.
#[expect(
    clippy::inline_always,
    reason = "inlined into its multiversioned caller, so the loop is compiled per vector unit"
)]
#[inline(always)]
fn sum_squares(x: &[f32]) -> f32 {
    let mut acc = [[0f32; 8]; 4];
    let blocks = x.chunks_exact(32);
    let tail = blocks.remainder();
    for b in blocks {
        for (a, v) in acc.iter_mut().zip(b.chunks_exact(8)) {
            for (s, &v) in a.iter_mut().zip(v) {
                *s += v * v;
            }
        }
    }
    let mut r = [0f32; 8];
    for (l, r) in r.iter_mut().enumerate() {
        *r = (acc[0][l] + acc[1][l]) + (acc[2][l] + acc[3][l]);
    }
    let t = [r[0] + r[4], r[1] + r[5], r[2] + r[6], r[3] + r[7]];
    let mut s = (t[0] + t[1]) + (t[2] + t[3]);
    for &v in tail {
        s += v * v;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::Device;

    /// The sums of squares and the merge give candle's own results bit for bit: squares
    /// summed by `sqr().sum_all()` (lengths with and without a tail, a transposed view) and
    /// shards merged as `g₀·w₀ + g₁·w₁` tensors.
    #[test]
    fn host_passes_match_candles_ops_bit_for_bit() {
        let values = |n: usize, seed: f32| -> Vec<f32> {
            (0..n)
                .map(|i| ((i as f32 * 0.731 + seed).sin() * 3.7).powi(3))
                .collect()
        };
        let candle = |t: &Tensor| {
            t.sqr()
                .unwrap()
                .sum_all()
                .unwrap()
                .to_scalar::<f32>()
                .unwrap()
        };
        for n in [1usize, 7, 31, 32, 33, 64, 100, 1000, 4099] {
            let x = values(n, 0.3);
            let t = Tensor::from_vec(x.clone(), n, &Device::Cpu).unwrap();
            assert_eq!(
                sum_squares(&x).to_bits(),
                candle(&t).to_bits(),
                "{n} values"
            );
        }
        // A transposed view, as backward hands over linear weights' gradients: candle squares
        // it into row-major order before summing, as `with_minibatch_grads` reads it.
        let t = Tensor::from_vec(values(41 * 29, 0.9), (41, 29), &Device::Cpu)
            .unwrap()
            .t()
            .unwrap();
        assert!(!t.is_contiguous());
        let x: Vec<f32> = t.flatten_all().unwrap().to_vec1().unwrap();
        assert_eq!(
            sum_squares(&x).to_bits(),
            candle(&t).to_bits(),
            "transposed"
        );
        let (rows, cols) = (37, 53);
        let var = Var::from_tensor(
            &Tensor::from_vec(values(rows * cols, 0.0), (rows, cols), &Device::Cpu).unwrap(),
        )
        .unwrap();
        let vars = BTreeMap::from([("w".to_owned(), var.clone())]);
        // Two shards' gradients of a linear layer: d/dW Σ (X·Wᵀ)⊙C.
        let stores: Vec<GradStore> = [1.0f32, 2.0]
            .iter()
            .map(|&s| {
                let x = Tensor::from_vec(values(5 * cols, s), (5, cols), &Device::Cpu).unwrap();
                let c =
                    Tensor::from_vec(values(5 * rows, s + 1.0), (5, rows), &Device::Cpu).unwrap();
                (x.matmul(&var.as_tensor().t().unwrap()).unwrap() * c)
                    .unwrap()
                    .sum_all()
                    .unwrap()
                    .backward()
                    .unwrap()
            })
            .collect();
        let shares = [0.375, 0.625];
        let g = |k: usize| stores[k].get(var.as_tensor()).unwrap();
        let want = ((g(0) * shares[0]).unwrap() + (g(1) * shares[1]).unwrap()).unwrap();
        let want_norm = f64::from(
            want.sqr()
                .unwrap()
                .sum_all()
                .unwrap()
                .to_scalar::<f32>()
                .unwrap(),
        )
        .sqrt();
        let want: Vec<u32> = want
            .flatten_all()
            .unwrap()
            .to_vec1::<f32>()
            .unwrap()
            .into_iter()
            .map(f32::to_bits)
            .collect();
        for threads in [1, 2, 3] {
            let (got, norm) = with_minibatch_grads(&vars, &stores, &shares, threads, |gs| {
                let got: Vec<u32> = gs[0].2.iter().map(|x| x.to_bits()).collect();
                Ok((got, clip_factor(gs, 1e9).0))
            })
            .unwrap();
            assert_eq!(got, want, "{threads} threads");
            assert_eq!(norm.to_bits(), want_norm.to_bits());
        }
        // One store: its gradient as it is, in row-major order.
        let one = with_minibatch_grads(&vars, &stores[..1], &[1.0], 2, |gs| Ok(gs[0].2.to_vec()))
            .unwrap();
        let want_one: Vec<f32> = g(0).flatten_all().unwrap().to_vec1().unwrap();
        assert_eq!(one, want_one);
        assert!(with_minibatch_grads(&vars, &stores, &[1.0], 1, |_| Ok(())).is_err());
    }
}
