//! The attention block, fused for training: from the keyed queries `Q̂ = Q W_k / √d_k`
//! (B, m, K, see [`crate::policy::attention::keyed_queries`]), the word mask (B, m) and the cell
//! features `Õ` (B, 49, K), the filtered features `F` (B, 49, K) — the scores
//! `S = Q̂ Õᵀ = Q Kcᵀ / √d_k`, eqs. 4–7 and the filter of [`crate::policy::attention`] in one CPU op
//! with a hand-written backward. The cells' keys `Kc` are never formed. The composite version
//! in `attention.rs` stays the definition (and computes the traces); `tests/it/policy/fused.rs`
//! compares.
//!
//! With the model's null key ([`attention_filter_null`]) each word's `Q̂` row carries one more
//! column, its null logit `Q_i k₀ᵀ / √d_k`, and its map is
//! [`crate::policy::attention::attention_maps_null`]'s.

use std::sync::{Mutex, PoisonError};

use candle_core::{CpuStorage, CustomOp3, Layout, Result, Shape, Tensor};

use super::f32_slice as slice;
use crate::policy::obs::N_CELLS;

/// Smallest probability fed to `ln`, as in `attention.rs`.
const TINY: f32 = 1e-30;

/// The forward op; `scale` is the filter's factor (`F_j = scale · M_j · Õ_j`), `t` the word
/// temperature (`w = softmax(−H / t)`).
struct AttentionFilter {
    dims: Dims,
    /// What the forward pass computed that the backward pass reads, left here by `cpu_fwd`
    /// and taken by `bwd`: recomputing the scores and maps (with their `exp` and `ln` per
    /// cell) was about half of the backward op's time.
    saved: Mutex<Option<Saved>>,
}

/// The sizes and constants both passes share.
#[derive(Clone, Copy)]
struct Dims {
    /// Words per frame.
    m: usize,
    /// Channels per cell.
    k: usize,
    /// The filter's factor.
    scale: f32,
    /// The word temperature.
    t: f32,
    /// Whether `Q̂`'s last column is the null key's logit.
    null: bool,
}

impl Dims {
    /// Columns of a `Q̂` row.
    fn width(self) -> usize {
        self.k + usize::from(self.null)
    }
}

/// Every frame's maps `a` and the logs of their clamped values `la` (B·m × 49), word weights
/// `w` and null probabilities `p0` (B·m), and `M` (B × 49).
struct Saved {
    a: Vec<f32>,
    la: Vec<f32>,
    w: Vec<f32>,
    p0: Vec<f32>,
    mm: Vec<f32>,
}

impl Saved {
    fn zeros(b: usize, m: usize) -> Self {
        Self {
            a: vec![0f32; b * m * N_CELLS],
            la: vec![0f32; b * m * N_CELLS],
            w: vec![0f32; b * m],
            p0: vec![0f32; b * m],
            mm: vec![0f32; b * N_CELLS],
        }
    }
}

/// Its backward: from `Q̂`, `Õ` and `dF` (the mask and the forward's [`Saved`] held in the
/// op), returns every frame's `dQ̂` (m × K, or m × (K + 1) with the null key) followed by every
/// frame's `dÕ` (49 × K), as one flat tensor.
struct AttentionFilterBackward {
    dims: Dims,
    /// The word mask, (B·m).
    mask: Vec<f32>,
    /// The forward's values, or `None` to compute them again.
    saved: Mutex<Option<Saved>>,
}

/// One frame's maps, weights and `M` (the slices of [`Saved`] for one frame), and room for
/// its words' `−H/t` (m).
struct FrameMaps<'a> {
    a: &'a mut [f32],
    la: &'a mut [f32],
    w: &'a mut [f32],
    p0: &'a mut [f32],
    mm: &'a mut [f32],
    neg_h: &'a mut [f32],
}

/// Per frame: maps `a` (m × 49), the logs `la` of their values clamped to [TINY, 1], weights
/// `w` (m) and `M` (49) from the scores and mask, at word temperature `t`. With `null` logits
/// (m) each word's softmax also runs over its null entry, whose probability goes to `p0` (m)
/// and is spread evenly over the word's map.
#[expect(
    clippy::inline_always,
    reason = "called from the loops compiled per vector unit; a call would keep it scalar"
)]
#[inline(always)]
fn maps(s: &[f32], null: Option<&[f32]>, mask: &[f32], t: f32, out: FrameMaps<'_>) {
    let FrameMaps {
        a,
        la,
        w,
        p0,
        mm,
        neg_h,
    } = out;
    let m = mask.len();
    for i in 0..m {
        let row = &s[i * N_CELLS..(i + 1) * N_CELLS];
        let ar = &mut a[i * N_CELLS..(i + 1) * N_CELLS];
        let lr = &mut la[i * N_CELLS..(i + 1) * N_CELLS];
        let mut max = row.iter().fold(f32::NEG_INFINITY, |x, y| x.max(*y));
        if let Some(n) = null {
            max = max.max(n[i]);
        }
        let mut z = 0f32;
        for (o, x) in ar.iter_mut().zip(row) {
            *o = (x - max).exp();
            z += *o;
        }
        let mut h = 0f32;
        if let Some(n) = null {
            let e0 = (n[i] - max).exp();
            z += e0;
            p0[i] = e0 / z;
            let spread = p0[i] / N_CELLS as f32;
            for o in ar.iter_mut() {
                *o = *o / z + spread;
            }
        } else {
            for o in ar.iter_mut() {
                *o /= z;
            }
        }
        for (l, o) in lr.iter_mut().zip(ar.iter()) {
            *l = o.clamp(TINY, 1.0).ln();
        }
        for (o, l) in ar.iter().zip(lr.iter()) {
            h -= o * l;
        }
        // Padding: −1e9 before the softmax, as `word_weights` (x / 1 is x, bit for bit).
        neg_h[i] = -h / t * mask[i] + (mask[i] - 1.0) * 1e9;
    }
    let max = neg_h.iter().fold(f32::NEG_INFINITY, |x, y| x.max(*y));
    let mut z = 0f32;
    for (o, x) in w.iter_mut().zip(neg_h.iter()) {
        *o = (x - max).exp();
        z += *o;
    }
    for o in w.iter_mut() {
        *o /= z;
    }
    mm.fill(0.0);
    for i in 0..m {
        for (mj, aij) in mm.iter_mut().zip(&a[i * N_CELLS..(i + 1) * N_CELLS]) {
            *mj += w[i] * aij;
        }
    }
}

/// Per frame: `S = Q̂ Õᵀ` (m × 49) from `Q̂` (m × `width`, of which the first K columns) and
/// `Õᵀ` (K × 49, `ot`); with the null key, each row's column K (its null logit) goes to `null`
/// (m). Each score sums its K products in order from −0, as `Iterator::sum` does, a channel
/// at a time over all 49 cells so that the cells fill the vector unit.
#[expect(
    clippy::inline_always,
    reason = "called from the loops compiled per vector unit; a call would keep it scalar"
)]
#[inline(always)]
fn scores(qk: &[f32], ot: &[f32], k: usize, width: usize, s: &mut [f32], null: &mut [f32]) {
    for (i, (si, qrow)) in s
        .chunks_exact_mut(N_CELLS)
        .zip(qk.chunks_exact(width))
        .enumerate()
    {
        // A fixed-size accumulator stays in registers across the channels.
        let mut acc = [-0.0f32; N_CELLS];
        for (q, oc) in qrow[..k].iter().zip(ot.chunks_exact(N_CELLS)) {
            let Some(oc) = oc.first_chunk::<N_CELLS>() else {
                continue;
            };
            for (sij, x) in acc.iter_mut().zip(oc) {
                *sij += q * x;
            }
        }
        si.copy_from_slice(&acc);
        if width > k {
            null[i] = qrow[k];
        }
    }
}

/// `Õ` (49 × K) transposed into `ot` (K × 49).
#[expect(
    clippy::inline_always,
    reason = "called from the loops compiled per vector unit; a call would keep it scalar"
)]
#[inline(always)]
fn transpose_cells(o: &[f32], k: usize, ot: &mut [f32]) {
    for (c, otc) in ot.chunks_exact_mut(N_CELLS).enumerate() {
        for (j, x) in otc.iter_mut().enumerate() {
            *x = o[j * k + c];
        }
    }
}

crate::multiversion! {
    /// The scores and maps of every frame (B = `mask.len() / m`) into `saved`, and the
    /// filtered features into `out` when given.
    fn forward_frames(
        qk: &[f32],
        mask: &[f32],
        o: &[f32],
        d: Dims,
        saved: &mut Saved,
        out: Option<&mut [f32]>,
    ) {
        let (m, k, width) = (d.m, d.k, d.width());
        let (mut s, mut null) = (vec![0f32; m * N_CELLS], vec![0f32; m]);
        let (mut ot, mut neg_h) = (vec![0f32; k * N_CELLS], vec![0f32; m]);
        let b = saved.mm.len() / N_CELLS;
        let mut out = out;
        for r in 0..b {
            let orow = &o[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            transpose_cells(orow, k, &mut ot);
            scores(&qk[r * m * width..(r + 1) * m * width], &ot, k, width, &mut s, &mut null);
            let mm = &mut saved.mm[r * N_CELLS..(r + 1) * N_CELLS];
            maps(
                &s,
                d.null.then_some(&null[..]),
                &mask[r * m..(r + 1) * m],
                d.t,
                FrameMaps {
                    a: &mut saved.a[r * m * N_CELLS..(r + 1) * m * N_CELLS],
                    la: &mut saved.la[r * m * N_CELLS..(r + 1) * m * N_CELLS],
                    w: &mut saved.w[r * m..(r + 1) * m],
                    p0: &mut saved.p0[r * m..(r + 1) * m],
                    mm: &mut *mm,
                    neg_h: &mut neg_h,
                },
            );
            if let Some(out) = out.as_deref_mut() {
                let dst = &mut out[r * N_CELLS * k..(r + 1) * N_CELLS * k];
                for ((dj, oj), mj) in dst.chunks_exact_mut(k).zip(orow.chunks_exact(k)).zip(mm.iter()) {
                    let f = mj * d.scale;
                    for (x, y) in dj.iter_mut().zip(oj) {
                        *x = y * f;
                    }
                }
            }
        }
    }
}

/// (B, m, K) from the shapes of `Q̂` (B, m, K, one more column with the null key), the mask
/// and `Õ`.
fn shapes(l1: &Layout, l2: &Layout, l3: &Layout, null: bool) -> Result<(usize, usize, usize)> {
    let (b, m, k1) = l1.shape().dims3()?;
    let (b2, m2) = l2.shape().dims2()?;
    let (b3, n3, k) = l3.shape().dims3()?;
    if k1 != k + usize::from(null) || n3 != N_CELLS || b2 != b || b3 != b || m2 != m {
        return Err(candle_core::Error::Msg(format!(
            "attention: shapes {:?}, {:?}, {:?} do not fit (B, m, K{}), (B, m), (B, 49, K)",
            l1.shape(),
            l2.shape(),
            l3.shape(),
            if null { " + 1" } else { "" }
        )));
    }
    Ok((b, m, k))
}

/// Takes what the op's slot holds, whether or not a thread panicked while holding it.
fn take(slot: &Mutex<Option<Saved>>) -> Option<Saved> {
    slot.lock().unwrap_or_else(PoisonError::into_inner).take()
}

impl CustomOp3 for AttentionFilter {
    fn name(&self) -> &'static str {
        "attention-filter"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
        s3: &CpuStorage,
        l3: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let (b, m, k) = shapes(l1, l2, l3, self.dims.null)?;
        let (qk, mask, o) = (
            slice(s1, l1, "attention: Q̂")?,
            slice(s2, l2, "attention: mask")?,
            slice(s3, l3, "attention: O")?,
        );
        let mut out = vec![0f32; b * N_CELLS * k];
        let mut saved = Saved::zeros(b, m);
        let d = Dims { m, k, ..self.dims };
        forward_frames(qk, mask, o, d, &mut saved, Some(&mut out));
        *self.saved.lock().unwrap_or_else(PoisonError::into_inner) = Some(saved);
        Ok((CpuStorage::F32(out), Shape::from((b, N_CELLS, k))))
    }

    fn bwd(
        &self,
        qk: &Tensor,
        mask: &Tensor,
        o: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        let (b, m, width) = qk.dims3()?;
        let k = width - usize::from(self.dims.null);
        // The mask (no gradient, B·m floats) rides in the op, leaving its inputs to Q̂, Õ, dF.
        let mask: Vec<f32> = mask.flatten_all()?.to_vec1()?;
        let both = qk.contiguous()?.apply_op3_no_bwd(
            &o.contiguous()?,
            &grad.contiguous()?,
            &AttentionFilterBackward {
                dims: Dims { m, k, ..self.dims },
                mask,
                // A second backward through the same graph finds nothing and computes again.
                saved: Mutex::new(take(&self.saved)),
            },
        )?;
        let dqk = both.narrow(0, 0, b * m * width)?.reshape((b, m, width))?;
        let d_o = both
            .narrow(0, b * m * width, b * N_CELLS * k)?
            .reshape((b, N_CELLS, k))?;
        Ok((Some(dqk), None, Some(d_o)))
    }
}

/// The backward pass's inputs: `Q̂`, the mask, `Õ` and `dF` of every frame.
#[derive(Clone, Copy)]
struct BackwardInputs<'a> {
    qk: &'a [f32],
    mask: &'a [f32],
    o_all: &'a [f32],
    df_all: &'a [f32],
}

crate::multiversion! {
    /// Every frame's `dQ̂` into `dqk_all` and `dÕ` into `d_o_all`, from the forward's values.
    fn backward_frames(
        x: BackwardInputs<'_>,
        d: Dims,
        saved: &Saved,
        dqk_all: &mut [f32],
        d_o_all: &mut [f32],
    ) {
        let (m, k, width, scale) = (d.m, d.k, d.width(), d.scale);
        let BackwardInputs { qk, mask, o_all, df_all } = x;
        let b = saved.mm.len() / N_CELLS;
        let mut dm = [0f32; N_CELLS];
        let mut da = vec![0f32; m * N_CELLS];
        let mut ds = vec![0f32; m * N_CELLS];
        let mut dw = vec![0f32; m];
        let dh_da_tiny = -TINY.ln();
        for r in 0..b {
            let qr = &qk[r * m * width..(r + 1) * m * width];
            let maskr = &mask[r * m..(r + 1) * m];
            let oj_all = &o_all[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            let df = &df_all[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            let a = &saved.a[r * m * N_CELLS..(r + 1) * m * N_CELLS];
            let la = &saved.la[r * m * N_CELLS..(r + 1) * m * N_CELLS];
            let w = &saved.w[r * m..(r + 1) * m];
            let p0 = &saved.p0[r * m..(r + 1) * m];
            let mm = &saved.mm[r * N_CELLS..(r + 1) * N_CELLS];
            let dqk = &mut dqk_all[r * m * width..(r + 1) * m * width];
            let d_o = &mut d_o_all[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            // F_j = 49·M_j·O_j.
            // The element-wise products and the sums in order are separate loops, so that
            // the former fill the vector unit while the latter keep their order.
            for ((doj, dfj), mj) in d_o.chunks_exact_mut(k).zip(df.chunks_exact(k)).zip(mm) {
                let f = scale * mj;
                for (x, g) in doj.iter_mut().zip(dfj) {
                    *x = f * g;
                }
            }
            for ((dmj, dfj), oj) in dm.iter_mut().zip(df.chunks_exact(k)).zip(oj_all.chunks_exact(k)) {
                let mut acc = 0f32;
                for (g, x) in dfj.iter().zip(oj) {
                    acc += g * x;
                }
                *dmj = scale * acc;
            }
            // M = Σ_i w_i A_i.
            for ((dwi, wi), (ai, dai)) in dw
                .iter_mut()
                .zip(w)
                .zip(a.chunks_exact(N_CELLS).zip(da.chunks_exact_mut(N_CELLS)))
            {
                let mut acc = 0f32;
                for (g, x) in dm.iter().zip(ai) {
                    acc += g * x;
                }
                *dwi = acc;
                for (x, g) in dai.iter_mut().zip(&dm) {
                    *x = wi * g;
                }
            }
            // w = softmax(−H/t·mask + (mask − 1)·1e9).
            let dot: f32 = w.iter().zip(&dw).map(|(x, y)| x * y).sum();
            for i in 0..m {
                let dz = w[i] * (dw[i] - dot);
                let dh = -dz / d.t * maskr[i];
                // H_i = −Σ_j A_ij ln clamp(A_ij): ∂H/∂A = −(ln A + 1) where A ≥ TINY. The
                // forward's log of the clamped value is ln A itself wherever A ≤ 1.
                for j in 0..N_CELLS {
                    let x = a[i * N_CELLS + j];
                    let dh_da = if x >= TINY {
                        let l = if x <= 1.0 { la[i * N_CELLS + j] } else { x.ln() };
                        -(l + 1.0)
                    } else {
                        dh_da_tiny
                    };
                    da[i * N_CELLS + j] += dh * dh_da;
                }
            }
            // A_i = softmax(S_i); with the null key A_ij = p_ij + p_i0 / 49 where
            // [p_i· | p_i0] = softmax([S_i | n_i]), and n_i's gradient goes to Q̂'s last column.
            for i in 0..m {
                let ai = &a[i * N_CELLS..(i + 1) * N_CELLS];
                let dai = &da[i * N_CELLS..(i + 1) * N_CELLS];
                let dsi = &mut ds[i * N_CELLS..(i + 1) * N_CELLS];
                if d.null {
                    let spread = p0[i] / N_CELLS as f32;
                    let dp0 = dai.iter().sum::<f32>() / N_CELLS as f32;
                    let dot = p0[i] * dp0
                        + ai.iter()
                            .zip(dai)
                            .map(|(x, y)| (x - spread) * y)
                            .sum::<f32>();
                    for j in 0..N_CELLS {
                        dsi[j] = (ai[j] - spread) * (dai[j] - dot);
                    }
                    dqk[i * width + k] = p0[i] * (dp0 - dot);
                } else {
                    let dot: f32 = ai.iter().zip(dai).map(|(x, y)| x * y).sum();
                    for j in 0..N_CELLS {
                        dsi[j] = ai[j] * (dai[j] - dot);
                    }
                }
            }
            // S = Q̂ Õᵀ: dQ̂ = dS Õ, dÕ += dSᵀ Q̂.
            for i in 0..m {
                let dsi = &ds[i * N_CELLS..(i + 1) * N_CELLS];
                let dqi = &mut dqk[i * width..i * width + k];
                dqi.fill(0.0);
                for (dsij, oj) in dsi.iter().zip(oj_all.chunks_exact(k)) {
                    for (dq, x) in dqi.iter_mut().zip(oj) {
                        *dq += dsij * x;
                    }
                }
                let qi = &qr[i * width..i * width + k];
                for (dsij, doj) in dsi.iter().zip(d_o.chunks_exact_mut(k)) {
                    for (dq, x) in doj.iter_mut().zip(qi) {
                        *dq += dsij * x;
                    }
                }
            }
        }
    }
}

impl CustomOp3 for AttentionFilterBackward {
    fn name(&self) -> &'static str {
        "attention-filter-backward"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
        s3: &CpuStorage,
        l3: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let d = self.dims;
        let (m, k, width) = (d.m, d.k, d.width());
        let (b, m1, k1) = l1.shape().dims3()?;
        if m1 != m
            || k1 != width
            || l2.shape().dims3()? != (b, N_CELLS, k)
            || l3.shape() != l2.shape()
            || self.mask.len() != b * m
        {
            return Err(candle_core::Error::Msg("attention backward: shapes".into()));
        }
        let (qk, mask, o_all, df_all) = (
            slice(s1, l1, "attention: Q̂")?,
            &self.mask,
            slice(s2, l2, "attention: O")?,
            slice(s3, l3, "attention: dF")?,
        );
        let saved = match take(&self.saved) {
            Some(s) if s.mm.len() == b * N_CELLS && s.a.len() == b * m * N_CELLS => s,
            _ => {
                let mut s = Saved::zeros(b, m);
                forward_frames(qk, mask, o_all, d, &mut s, None);
                s
            }
        };
        // All rows' dQ̂ first, then all rows' dÕ: each half is a contiguous tensor on its own,
        // so splitting the output costs no copy (row-interleaved halves had to be copied).
        let mut out = vec![0f32; b * m * width + b * N_CELLS * k];
        let (dqk_all, d_o_all) = out.split_at_mut(b * m * width);
        let x = BackwardInputs {
            qk,
            mask,
            o_all,
            df_all,
        };
        backward_frames(x, d, &saved, dqk_all, d_o_all);
        let len = out.len();
        Ok((CpuStorage::F32(out), Shape::from(len)))
    }
}

/// `F` (B, 49, K) from the keyed queries `Q̂` (B, m, K), the word mask (B, m) and `Õ`
/// (B, 49, K), with the filter's factor `scale` (`F_j = scale · M_j · Õ_j`; see
/// [`crate::policy::attention::filter_features`]) and the word temperature `t` (see
/// [`crate::policy::attention::word_weights`]).
pub fn attention_filter(
    keyed: &Tensor,
    mask: &Tensor,
    o: &Tensor,
    scale: u32,
    t: f32,
) -> Result<Tensor> {
    apply(keyed, mask, o, scale, t, false)
}

/// [`attention_filter`] with the null key: `keyed` is (B, m, K + 1), each row's last column
/// the word's null logit `Q_i k₀ᵀ / √d_k` ([`crate::policy::attention::null_logits`]); its
/// gradient comes back in that column.
pub fn attention_filter_null(
    keyed: &Tensor,
    mask: &Tensor,
    o: &Tensor,
    scale: u32,
    t: f32,
) -> Result<Tensor> {
    apply(keyed, mask, o, scale, t, true)
}

fn apply(
    keyed: &Tensor,
    mask: &Tensor,
    o: &Tensor,
    scale: u32,
    t: f32,
    null: bool,
) -> Result<Tensor> {
    keyed.contiguous()?.apply_op3(
        &mask.contiguous()?,
        &o.contiguous()?,
        AttentionFilter {
            dims: Dims {
                // Set from the shapes by `cpu_fwd`.
                m: 0,
                k: 0,
                // Small integers (1 or 49) are exact in f32.
                scale: scale as f32,
                t,
                null,
            },
            saved: Mutex::new(None),
        },
    )
}
