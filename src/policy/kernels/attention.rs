//! The attention block, fused for training: from the keyed queries `Q̂ = Q W_k / √d_k`
//! (B, m, K, see [`crate::policy::attention::keyed_queries`]), the word mask (B, m) and the cell
//! features `Õ` (B, 49, K), the filtered features `F` (B, 49, K) — the scores
//! `S = Q̂ Õᵀ = Q Kcᵀ / √d_k`, eqs. 4–7 and the filter of [`crate::policy::attention`] in one CPU op
//! with a hand-written backward. The cells' keys `Kc` are never formed. The composite version
//! in `attention.rs` stays the definition (and computes the traces); `tests/fused.rs`
//! compares.
//!
//! With the model's null key ([`attention_filter_null`]) each word's `Q̂` row carries one more
//! column, its null logit `Q_i k₀ᵀ / √d_k`, and its map is
//! [`crate::policy::attention::attention_maps_null`]'s.

use candle_core::{CpuStorage, CustomOp3, Layout, Result, Shape, Tensor};

use super::f32_slice as slice;
use crate::policy::obs::N_CELLS;

/// Smallest probability fed to `ln`, as in `attention.rs`.
const TINY: f32 = 1e-30;

/// The forward op; `scale` is the filter's factor (`F_j = scale · M_j · Õ_j`), `t` the word
/// temperature (`w = softmax(−H / t)`).
struct AttentionFilter {
    scale: f32,
    t: f32,
    /// Whether `Q̂`'s last column is the null key's logit.
    null: bool,
}

/// Its backward: from `Q̂`, `Õ` and `dF` (the mask held in the op), returns every frame's `dQ̂`
/// (m × K, or m × (K + 1) with the null key) followed by every frame's `dÕ` (49 × K), as one
/// flat tensor.
struct AttentionFilterBackward {
    m: usize,
    k: usize,
    scale: f32,
    t: f32,
    null: bool,
    /// The word mask, (B·m).
    mask: Vec<f32>,
}

/// Per frame: maps `a` (m × 49), weights `w` (m) and `M` (49) from the scores and mask, at
/// word temperature `t`. With `null` logits (m) each word's softmax also runs over its null
/// entry, whose probability goes to `p0` (m) and is spread evenly over the word's map.
#[expect(
    clippy::too_many_arguments,
    reason = "one frame's inputs and the four buffers the forward and backward passes both fill"
)]
fn maps(
    s: &[f32],
    null: Option<&[f32]>,
    mask: &[f32],
    t: f32,
    a: &mut [f32],
    p0: &mut [f32],
    w: &mut [f32],
    m_out: &mut [f32],
) {
    let m = mask.len();
    let mut neg_h = vec![0f32; m];
    for i in 0..m {
        let row = &s[i * N_CELLS..(i + 1) * N_CELLS];
        let ar = &mut a[i * N_CELLS..(i + 1) * N_CELLS];
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
                h -= *o * o.clamp(TINY, 1.0).ln();
            }
        } else {
            for o in ar.iter_mut() {
                *o /= z;
                h -= *o * o.clamp(TINY, 1.0).ln();
            }
        }
        // Padding: −1e9 before the softmax, as `word_weights` (x / 1 is x, bit for bit).
        neg_h[i] = -h / t * mask[i] + (mask[i] - 1.0) * 1e9;
    }
    let max = neg_h.iter().fold(f32::NEG_INFINITY, |x, y| x.max(*y));
    let mut z = 0f32;
    for (o, x) in w.iter_mut().zip(&neg_h) {
        *o = (x - max).exp();
        z += *o;
    }
    for o in w.iter_mut() {
        *o /= z;
    }
    m_out.fill(0.0);
    for i in 0..m {
        for j in 0..N_CELLS {
            m_out[j] += w[i] * a[i * N_CELLS + j];
        }
    }
}

/// Per frame: `S = Q̂ Õᵀ` (m × 49) from `Q̂` (m × `width`, of which the first K columns) and
/// `Õ` (49 × K); with the null key, each row's column K (its null logit) goes to `null` (m).
fn scores(qk: &[f32], o: &[f32], k: usize, width: usize, s: &mut [f32], null: &mut [f32]) {
    for (i, (si, qrow)) in s
        .chunks_exact_mut(N_CELLS)
        .zip(qk.chunks_exact(width))
        .enumerate()
    {
        let qi = &qrow[..k];
        for (sij, oj) in si.iter_mut().zip(o.chunks_exact(k)) {
            *sij = qi.iter().zip(oj).map(|(x, y)| x * y).sum();
        }
        if width > k {
            null[i] = qrow[k];
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
        let (b, m, k) = shapes(l1, l2, l3, self.null)?;
        let width = k + usize::from(self.null);
        let (qk, mask, o) = (
            slice(s1, l1, "attention: Q̂")?,
            slice(s2, l2, "attention: mask")?,
            slice(s3, l3, "attention: O")?,
        );
        let mut out = vec![0f32; b * N_CELLS * k];
        let (mut a, mut w, mut mm) = (vec![0f32; m * N_CELLS], vec![0f32; m], vec![0f32; N_CELLS]);
        let (mut s, mut null, mut p0) = (vec![0f32; m * N_CELLS], vec![0f32; m], vec![0f32; m]);
        let scale = self.scale;
        for r in 0..b {
            scores(
                &qk[r * m * width..(r + 1) * m * width],
                &o[r * N_CELLS * k..(r + 1) * N_CELLS * k],
                k,
                width,
                &mut s,
                &mut null,
            );
            maps(
                &s,
                self.null.then_some(&null[..]),
                &mask[r * m..(r + 1) * m],
                self.t,
                &mut a,
                &mut p0,
                &mut w,
                &mut mm,
            );
            for (j, mj) in mm.iter().enumerate() {
                let f = mj * scale;
                let base = (r * N_CELLS + j) * k;
                for (dst, x) in out[base..base + k].iter_mut().zip(&o[base..base + k]) {
                    *dst = x * f;
                }
            }
        }
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
        let k = width - usize::from(self.null);
        // The mask (no gradient, B·m floats) rides in the op, leaving its inputs to Q̂, Õ, dF.
        let mask: Vec<f32> = mask.flatten_all()?.to_vec1()?;
        let both = qk.contiguous()?.apply_op3_no_bwd(
            &o.contiguous()?,
            &grad.contiguous()?,
            &AttentionFilterBackward {
                m,
                k,
                scale: self.scale,
                t: self.t,
                null: self.null,
                mask,
            },
        )?;
        let dqk = both.narrow(0, 0, b * m * width)?.reshape((b, m, width))?;
        let d_o = both
            .narrow(0, b * m * width, b * N_CELLS * k)?
            .reshape((b, N_CELLS, k))?;
        Ok((Some(dqk), None, Some(d_o)))
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
        let (m, k) = (self.m, self.k);
        let width = k + usize::from(self.null);
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
        // All rows' dQ̂ first, then all rows' dÕ: each half is a contiguous tensor on its own,
        // so splitting the output costs no copy (row-interleaved halves had to be copied).
        let mut out = vec![0f32; b * m * width + b * N_CELLS * k];
        let (dqk_all, d_o_all) = out.split_at_mut(b * m * width);
        let (mut a, mut w, mut mm) = (vec![0f32; m * N_CELLS], vec![0f32; m], vec![0f32; N_CELLS]);
        let (mut null, mut p0) = (vec![0f32; m], vec![0f32; m]);
        let scale = self.scale;
        let mut dm = [0f32; N_CELLS];
        let mut da = vec![0f32; m * N_CELLS];
        let mut ds = vec![0f32; m * N_CELLS];
        let mut dw = vec![0f32; m];
        for r in 0..b {
            let qr = &qk[r * m * width..(r + 1) * m * width];
            let maskr = &mask[r * m..(r + 1) * m];
            let oj_all = &o_all[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            let df = &df_all[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            scores(qr, oj_all, k, width, &mut ds, &mut null);
            let nl = self.null.then_some(&null[..]);
            maps(&ds, nl, maskr, self.t, &mut a, &mut p0, &mut w, &mut mm);
            let dqk = &mut dqk_all[r * m * width..(r + 1) * m * width];
            let d_o = &mut d_o_all[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            // F_j = 49·M_j·O_j.
            for j in 0..N_CELLS {
                let (oj, dfj) = (&oj_all[j * k..(j + 1) * k], &df[j * k..(j + 1) * k]);
                let mut acc = 0f32;
                for c in 0..k {
                    d_o[j * k + c] = scale * mm[j] * dfj[c];
                    acc += dfj[c] * oj[c];
                }
                dm[j] = scale * acc;
            }
            // M = Σ_i w_i A_i.
            dw.fill(0.0);
            for i in 0..m {
                for j in 0..N_CELLS {
                    dw[i] += dm[j] * a[i * N_CELLS + j];
                    da[i * N_CELLS + j] = w[i] * dm[j];
                }
            }
            // w = softmax(−H/t·mask + (mask − 1)·1e9).
            let dot: f32 = w.iter().zip(&dw).map(|(x, y)| x * y).sum();
            for i in 0..m {
                let dz = w[i] * (dw[i] - dot);
                let dh = -dz / self.t * maskr[i];
                // H_i = −Σ_j A_ij ln clamp(A_ij): ∂H/∂A = −(ln A + 1) where A ≥ TINY.
                for j in 0..N_CELLS {
                    let x = a[i * N_CELLS + j];
                    let dh_da = if x >= TINY {
                        -(x.ln() + 1.0)
                    } else {
                        -TINY.ln()
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
                if self.null {
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
                    for (d, x) in dqi.iter_mut().zip(oj) {
                        *d += dsij * x;
                    }
                }
                let qi = &qr[i * width..i * width + k];
                for (dsij, doj) in dsi.iter().zip(d_o.chunks_exact_mut(k)) {
                    for (d, x) in doj.iter_mut().zip(qi) {
                        *d += dsij * x;
                    }
                }
            }
        }
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
            // Small integers (1 or 49) are exact in f32.
            scale: scale as f32,
            t,
            null,
        },
    )
}
