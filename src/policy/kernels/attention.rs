//! The attention block, fused for training: from the keyed queries `Q̂ = Q W_k / √d_k`
//! (B, m, K, see [`crate::policy::attention::keyed_queries`]), the word mask (B, m) and the cell
//! features `Õ` (B, 49, K), the filtered features `F` (B, 49, K) — the scores
//! `S = Q̂ Õᵀ = Q Kcᵀ / √d_k`, eqs. 4–7 and the filter of [`crate::policy::attention`] in one CPU op
//! with a hand-written backward. The cells' keys `Kc` are never formed. The composite version
//! in `attention.rs` stays the definition (and computes the traces); `tests/fused.rs`
//! compares.

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
}

/// Its backward: from `Q̂`, `Õ` and `dF` (the mask held in the op), returns `[dQ̂ (m·K) | dÕ (49·K)]` per
/// frame as one (B, m·K + 49·K) tensor.
struct AttentionFilterBackward {
    m: usize,
    k: usize,
    scale: f32,
    t: f32,
    /// The word mask, (B·m).
    mask: Vec<f32>,
}

/// Per frame: maps `a` (m × 49), weights `w` (m) and `M` (49) from the scores and mask, at
/// word temperature `t`.
fn maps(s: &[f32], mask: &[f32], t: f32, a: &mut [f32], w: &mut [f32], m_out: &mut [f32]) {
    let m = mask.len();
    let mut neg_h = vec![0f32; m];
    for i in 0..m {
        let row = &s[i * N_CELLS..(i + 1) * N_CELLS];
        let ar = &mut a[i * N_CELLS..(i + 1) * N_CELLS];
        let max = row.iter().fold(f32::NEG_INFINITY, |x, y| x.max(*y));
        let mut z = 0f32;
        for (o, x) in ar.iter_mut().zip(row) {
            *o = (x - max).exp();
            z += *o;
        }
        let mut h = 0f32;
        for o in ar.iter_mut() {
            *o /= z;
            h -= *o * o.clamp(TINY, 1.0).ln();
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

/// Per frame: `S = Q̂ Õᵀ` (m × 49) from `Q̂` (m × K) and `Õ` (49 × K).
fn scores(qk: &[f32], o: &[f32], k: usize, s: &mut [f32]) {
    for (si, qi) in s.chunks_exact_mut(N_CELLS).zip(qk.chunks_exact(k)) {
        for (sij, oj) in si.iter_mut().zip(o.chunks_exact(k)) {
            *sij = qi.iter().zip(oj).map(|(x, y)| x * y).sum();
        }
    }
}

fn shapes(l1: &Layout, l2: &Layout, l3: &Layout) -> Result<(usize, usize, usize)> {
    let (b, m, k1) = l1.shape().dims3()?;
    let (b2, m2) = l2.shape().dims2()?;
    let (b3, n3, k) = l3.shape().dims3()?;
    if k1 != k || n3 != N_CELLS || b2 != b || b3 != b || m2 != m {
        return Err(candle_core::Error::Msg(format!(
            "attention: shapes {:?}, {:?}, {:?} do not fit (B, m, K), (B, m), (B, 49, K)",
            l1.shape(),
            l2.shape(),
            l3.shape()
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
        let (b, m, k) = shapes(l1, l2, l3)?;
        let (qk, mask, o) = (
            slice(s1, l1, "attention: Q̂")?,
            slice(s2, l2, "attention: mask")?,
            slice(s3, l3, "attention: O")?,
        );
        let mut out = vec![0f32; b * N_CELLS * k];
        let (mut a, mut w, mut mm) = (vec![0f32; m * N_CELLS], vec![0f32; m], vec![0f32; N_CELLS]);
        let mut s = vec![0f32; m * N_CELLS];
        let scale = self.scale;
        for r in 0..b {
            scores(
                &qk[r * m * k..(r + 1) * m * k],
                &o[r * N_CELLS * k..(r + 1) * N_CELLS * k],
                k,
                &mut s,
            );
            maps(
                &s,
                &mask[r * m..(r + 1) * m],
                self.t,
                &mut a,
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
        let (b, m, k) = qk.dims3()?;
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
                mask,
            },
        )?;
        let dqk = both.narrow(0, 0, b * m * k)?.reshape((b, m, k))?;
        let d_o = both
            .narrow(0, b * m * k, b * N_CELLS * k)?
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
        let (b, m1, k1) = l1.shape().dims3()?;
        if m1 != m
            || k1 != k
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
        let mut out = vec![0f32; b * (m + N_CELLS) * k];
        let (dqk_all, d_o_all) = out.split_at_mut(b * m * k);
        let (mut a, mut w, mut mm) = (vec![0f32; m * N_CELLS], vec![0f32; m], vec![0f32; N_CELLS]);
        let scale = self.scale;
        let mut dm = [0f32; N_CELLS];
        let mut da = vec![0f32; m * N_CELLS];
        let mut ds = vec![0f32; m * N_CELLS];
        let mut dw = vec![0f32; m];
        for r in 0..b {
            let qr = &qk[r * m * k..(r + 1) * m * k];
            let maskr = &mask[r * m..(r + 1) * m];
            let oj_all = &o_all[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            let df = &df_all[r * N_CELLS * k..(r + 1) * N_CELLS * k];
            scores(qr, oj_all, k, &mut ds);
            maps(&ds, maskr, self.t, &mut a, &mut w, &mut mm);
            let dqk = &mut dqk_all[r * m * k..(r + 1) * m * k];
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
            // A_i = softmax(S_i).
            for i in 0..m {
                let ai = &a[i * N_CELLS..(i + 1) * N_CELLS];
                let dai = &da[i * N_CELLS..(i + 1) * N_CELLS];
                let dot: f32 = ai.iter().zip(dai).map(|(x, y)| x * y).sum();
                for j in 0..N_CELLS {
                    ds[i * N_CELLS + j] = ai[j] * (dai[j] - dot);
                }
            }
            // S = Q̂ Õᵀ: dQ̂ = dS Õ, dÕ += dSᵀ Q̂.
            for i in 0..m {
                let dsi = &ds[i * N_CELLS..(i + 1) * N_CELLS];
                let dqi = &mut dqk[i * k..(i + 1) * k];
                dqi.fill(0.0);
                for (dsij, oj) in dsi.iter().zip(oj_all.chunks_exact(k)) {
                    for (d, x) in dqi.iter_mut().zip(oj) {
                        *d += dsij * x;
                    }
                }
                let qi = &qr[i * k..(i + 1) * k];
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
    keyed.contiguous()?.apply_op3(
        &mask.contiguous()?,
        &o.contiguous()?,
        AttentionFilter {
            // Small integers (1 or 49) are exact in f32.
            scale: scale as f32,
            t,
        },
    )
}
