//! A minibatch's gradient on the host, for the optimizer: its shards' gradients merged as
//! they are read, and the global norm with torch's clip factor. The merge is not written to
//! a buffer of its own: the norm and Adam each merge a cache-sized chunk at a time, which
//! spares a zeroed allocation, a write and a read of every parameter per minibatch (with two
//! threads, zeroing and merging into those buffers took half of the optimizer's time, the
//! serial norm another tenth). Before that, candle ops allocated a
//! tensor per parameter for the merge and another for the norm's squares, while the second
//! update thread waited (issue #16).

use std::collections::BTreeMap;
use std::ops::Range;

use candle_core::backprop::GradStore;
use candle_core::{Tensor, Var};

use crate::policy::error::PolicyError;
use crate::policy::kernels::cpu_f32;

/// One parameter's gradient: its name, its variable and its values.
pub type ParamGrad<'a> = (&'a str, &'a Var, Grad<'a>);

/// One shard's term of a parameter's gradient: the values and the shard's share of the
/// minibatch.
type Term<'a> = (&'a [f32], f32);

/// One parameter's name, variable and contiguous gradient terms (tensor, share).
type ParamTerms<'a> = (&'a str, &'a Var, Vec<(Tensor, f32)>);

/// How many merged values a [`Grad`] hands over at a time: a multiple of the norm's 32-value
/// blocks, small enough for the first-level cache.
const CHUNK: usize = 1024;

/// A parameter's minibatch gradient in row-major order, `Σ share_k · g_k` over the shards'
/// terms, each term computed as candle's `g * share` (`g · share + 0` in f32) and added in
/// shard order; one store's gradient is taken as it is.
pub struct Grad<'a> {
    terms: Vec<Term<'a>>,
    /// One store: its values as they are, not scaled by its share.
    whole: bool,
}

impl Grad<'_> {
    /// The number of values.
    pub fn len(&self) -> usize {
        self.terms.first().map_or(0, |(g, _)| g.len())
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Calls `f(offset, values)` with the values of `range` in order, `offset` counted from
    /// the range's start: at once for one store, else [`CHUNK`] at a time (so every call but
    /// the last of a range that starts at 0 begins at a multiple of 32).
    pub fn for_each_chunk(&self, range: Range<usize>, mut f: impl FnMut(usize, &[f32])) {
        if self.whole {
            if let Some((g, _)) = self.terms.first() {
                f(0, &g[range]);
            }
            return;
        }
        let mut buf = [0f32; CHUNK];
        let mut lo = range.start;
        while lo < range.end {
            let hi = (lo + CHUNK).min(range.end);
            let out = &mut buf[..hi - lo];
            for (k, &(g, w)) in self.terms.iter().enumerate() {
                add_term(out, &g[lo..hi], w, k == 0);
            }
            f(lo - range.start, out);
            lo = hi;
        }
    }

    /// Every value, merged.
    pub fn to_vec(&self) -> Vec<f32> {
        let mut v = Vec::with_capacity(self.len());
        self.for_each_chunk(0..self.len(), |_, c| v.extend_from_slice(c));
        v
    }

    /// `Σ x²` over the values in f32, in candle's order (see [`square_blocks`]).
    fn sum_squares(&self) -> f32 {
        let n = self.len();
        let blocks = n - n % 32;
        let mut acc = [[0f32; 8]; 4];
        let mut tail = 0f32;
        self.for_each_chunk(0..n, |off, c| {
            let whole = c.len().min(blocks.saturating_sub(off));
            square_blocks_simd(&mut acc, &c[..whole]);
            if whole < c.len() {
                tail = finish_squares_simd(&acc, &c[whole..]);
            }
        });
        if blocks == n {
            finish_squares_simd(&acc, &[])
        } else {
            tail
        }
    }
}

/// Calls `f` with the minibatch gradient of every parameter of `vars` that has one (in name
/// order): `Σ share_k · g_k` over the shards' stores (see [`Grad`]).
pub fn with_minibatch_grads<R>(
    vars: &BTreeMap<String, Var>,
    stores: &[GradStore],
    shares: &[f64],
    f: impl FnOnce(&[ParamGrad<'_>]) -> Result<R, PolicyError>,
) -> Result<R, PolicyError> {
    if stores.is_empty() || stores.len() != shares.len() {
        return Err(PolicyError::Input(format!(
            "{} gradient stores for {} shares",
            stores.len(),
            shares.len()
        )));
    }
    // Each parameter's terms, contiguous.
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
    let mut grads: Vec<ParamGrad<'_>> = Vec::with_capacity(terms.len());
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
        grads.push((
            name,
            var,
            Grad {
                terms: s,
                whole: stores.len() == 1,
            },
        ));
    }
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
    /// [`square_blocks`] compiled for the CPU's vector unit: its accumulators are explicit,
    /// so every clone adds in the same order.
    fn square_blocks_simd(acc: &mut [[f32; 8]; 4], x: &[f32]) {
        square_blocks(acc, x);
    }
}

crate::multiversion! {
    /// [`finish_squares`] compiled for the CPU's vector unit.
    fn finish_squares_simd(acc: &[[f32; 8]; 4], tail: &[f32]) -> f32 {
        finish_squares(acc, tail)
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
/// `max_norm / (‖g‖ + 1e-6)` where that is below 1). Each parameter's sum is taken whole by
/// one of `threads` (the largest first, each to the least loaded), so the count never
/// changes a bit.
pub fn clip_factor(
    grads: &[ParamGrad<'_>],
    max_norm: f64,
    threads: usize,
) -> Result<(f64, Option<f64>), PolicyError> {
    let mut order: Vec<usize> = (0..grads.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(grads[i].2.len()));
    let mut lists: Vec<(usize, Vec<usize>)> =
        vec![(0, Vec::new()); threads.clamp(1, grads.len().max(1))];
    for i in order {
        if let Some(l) = lists.iter_mut().min_by_key(|(load, _)| *load) {
            l.0 += grads[i].2.len();
            l.1.push(i);
        }
    }
    let sums = super::workers::run_all(
        lists
            .iter()
            .map(|(_, list)| {
                move || -> Result<Vec<(usize, f32)>, PolicyError> {
                    Ok(list
                        .iter()
                        .map(|&i| (i, grads[i].2.sum_squares()))
                        .collect())
                }
            })
            .collect(),
    )?;
    let mut squares = vec![0f32; grads.len()];
    for (i, s) in sums.into_iter().flatten() {
        squares[i] = s;
    }
    let sq: f64 = squares.into_iter().map(f64::from).sum();
    let norm = sq.sqrt();
    let scale = max_norm / (norm + 1e-6);
    Ok((norm, (scale < 1.0).then_some(scale)))
}

/// `Σ x²` of one buffer: the reference the chunked sums are tested against.
#[cfg(test)]
fn sum_squares(x: &[f32]) -> f32 {
    let mut acc = [[0f32; 8]; 4];
    let whole = x.len() - x.len() % 32;
    square_blocks(&mut acc, &x[..whole]);
    finish_squares(&acc, &x[whole..])
}

/// `Σ x²` is added as candle's `x.sqr()?.sum_all()` adds it on a CPU with AVX2 (its
/// `vec_sum`), so that the clip factor keeps the bits it had as candle ops: four 8-lane
/// accumulators over blocks of 32 values (this function; `x` holds whole blocks), reduced
/// pairwise, then the remaining values in order ([`finish_squares`]).
#[expect(
    clippy::inline_always,
    reason = "inlined into its multiversioned caller, so the loop is compiled per vector unit"
)]
#[inline(always)]
fn square_blocks(acc: &mut [[f32; 8]; 4], x: &[f32]) {
    for b in x.chunks_exact(32) {
        for (a, v) in acc.iter_mut().zip(b.chunks_exact(8)) {
            for (s, &v) in a.iter_mut().zip(v) {
                *s += v * v;
            }
        }
    }
}

/// The end of a sum of squares ([`square_blocks`]): the accumulators reduced pairwise, then
/// the tail's squares in order.
#[expect(
    clippy::inline_always,
    reason = "inlined into its multiversioned caller, so the loop is compiled per vector unit"
)]
#[inline(always)]
fn finish_squares(acc: &[[f32; 8]; 4], tail: &[f32]) -> f32 {
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

    /// A merged gradient read a chunk at a time gives the values and the sum of squares of the
    /// whole merged buffer (lengths around the chunk and block sizes, one to three shards, any
    /// sub-range).
    #[test]
    fn chunked_merge_matches_the_merged_buffer() {
        let values = |n: usize, seed: f32| -> Vec<f32> {
            (0..n)
                .map(|i| ((i as f32 * 0.517 + seed).cos() * 2.3).powi(3))
                .collect()
        };
        for n in [1usize, 31, 32, 33, 1000, 1024, 1029, 2053, 2080, 3000] {
            let shards: Vec<Vec<f32>> = (0..3).map(|k| values(n, k as f32)).collect();
            for stores in 1..=3 {
                let weights = [0.25f32, 0.5, 0.125];
                let grad = Grad {
                    terms: shards[..stores]
                        .iter()
                        .zip(weights)
                        .map(|(g, w)| (g.as_slice(), w))
                        .collect(),
                    whole: stores == 1,
                };
                let mut merged = vec![0f32; n];
                if stores == 1 {
                    merged.clone_from(&shards[0]);
                } else {
                    for (k, (g, w)) in shards[..stores].iter().zip(weights).enumerate() {
                        add_term(&mut merged, g, w, k == 0);
                    }
                }
                assert_eq!(grad.to_vec(), merged, "{n} values, {stores} stores");
                assert_eq!(
                    grad.sum_squares().to_bits(),
                    sum_squares(&merged).to_bits(),
                    "{n} values, {stores} stores"
                );
                let (lo, hi) = (n / 3, n - n / 5);
                let mut got = Vec::new();
                grad.for_each_chunk(lo..hi, |off, c| {
                    assert_eq!(off, got.len());
                    got.extend_from_slice(c);
                });
                assert_eq!(got, merged[lo..hi], "{n} values, {stores} stores, a range");
            }
        }
    }

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
            let (got, norm) = with_minibatch_grads(&vars, &stores, &shares, |gs| {
                let got: Vec<u32> = gs[0].2.to_vec().iter().map(|x| x.to_bits()).collect();
                Ok((got, clip_factor(gs, 1e9, threads)?.0))
            })
            .unwrap();
            assert_eq!(got, want, "{threads} threads");
            assert_eq!(norm.to_bits(), want_norm.to_bits());
        }
        // One store: its gradient as it is, in row-major order.
        let one =
            with_minibatch_grads(&vars, &stores[..1], &[1.0], |gs| Ok(gs[0].2.to_vec())).unwrap();
        let want_one: Vec<f32> = g(0).flatten_all().unwrap().to_vec1().unwrap();
        assert_eq!(one, want_one);
        assert!(with_minibatch_grads(&vars, &stores, &[1.0], |_| Ok(())).is_err());
    }
}
