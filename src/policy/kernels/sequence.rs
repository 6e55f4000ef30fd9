//! A whole recurrent chunk of LSTM steps as one op for training (issue #16). Step by step,
//! candle's autograd records a narrow of the input projection, the memory masking, a matmul
//! and the gates per step, and the backward of each narrow materialises a zero-padded copy of
//! the full input gradient: work that grows with the square of the recurrence. Here the
//! forward runs the steps on the host (the recurrent product through candle's matmul) and a
//! hand-written backward through time returns the gradients of the projected inputs, `W_hh`
//! and the initial memory at once. [`crate::policy::model::Net::lstm_cell_reference`] stepped in a
//! loop is the reference; `tests/it/policy/fused.rs` compares.

use std::sync::Arc;

use candle_core::{CpuStorage, CustomOp3, Device, Layout, Result, Shape, Tensor};

use super::{cpu_f32, f32_slice as slice, gate_activations, tanh_fast};

/// The op: inputs `gx` (T·n, 4H, both biases included), `W_hh` (4H, H) and `[h0 | c0]`
/// (n, 2H); output per frame `[h | c | g]` (T·n, 6H) with `g` the gate pre-activations,
/// kept for the backward.
struct LstmSequence {
    /// (T·n) 1 where the memory carries over into step t, 0 where an episode starts.
    keep: Arc<[f32]>,
    n: usize,
    /// `W_hhᵀ` made contiguous by the caller (an acting net keeps one), if any.
    w_hh_t: Option<Tensor>,
}

/// `W_hh` (4H or 3H rows) for the steps' `x · W_hhᵀ` ([`super::times_transposed`]), with its
/// contiguous transpose from two rows on: candle hands a strided `W.t()` to gemm, which then
/// repacks all of it at every step.
pub(super) struct Recurrent {
    w: Tensor,
    wt: Option<Tensor>,
}

impl Recurrent {
    /// From `W_hh` (4H, H) row-major, and the transpose the caller already keeps (`wt`).
    pub(super) fn new(
        w: &[f32],
        wt: Option<&Tensor>,
        h4: usize,
        h: usize,
        rows: usize,
    ) -> Result<Self> {
        let w = Tensor::from_slice(w, (h4, h), &Device::Cpu)?;
        let wt = match wt {
            Some(wt) if wt.dims() == [h, h4] && wt.is_contiguous() => Some(wt.clone()),
            _ if rows >= 2 => Some(w.t()?.contiguous()?),
            _ => None,
        };
        Ok(Self { w, wt })
    }

    /// `x · W_hhᵀ` for `x` (rows, H) on the host through candle's matmul.
    pub(super) fn times(&self, x: &[f32], rows: usize) -> Result<Vec<f32>> {
        let x = Tensor::from_slice(x, (rows, self.w.dim(1)?), &Device::Cpu)?;
        super::times_transposed(&x, &self.w, self.wt.as_ref())?
            .flatten_all()?
            .to_vec1()
    }
}

crate::multiversion! {
    /// One step's gates for its n rows: `g = gx + rec` (n, 4H) and the new `[h | c]` from the
    /// masked previous cell state `cm` (n, H), written into the step's `[h | c | g]` rows.
    fn step_forward(gx: &[f32], rec: &[f32], cm: &[f32], h: usize, out: &mut [f32]) {
        let (h4, width) = (4 * h, 6 * h);
        for j in 0..cm.len().checked_div(h).unwrap_or(0) {
            let (hc, g) = out[j * width..(j + 1) * width].split_at_mut(2 * h);
            for (k, gk) in g.iter_mut().enumerate() {
                *gk = gx[j * h4 + k] + rec[j * h4 + k];
            }
            let (ho, co) = hc.split_at_mut(h);
            for k in 0..h {
                let (i, f, gg, o) = gate_activations(g, h, k);
                let c = f * cm[j * h + k] + i * gg;
                co[k] = c;
                ho[k] = o * tanh_fast(c);
            }
        }
    }
}

/// What [`step_backward`] reads for one step's n rows.
struct StepRows<'a> {
    /// (n) 1 where the memory carried over into this step.
    keep: &'a [f32],
    /// The previous `[h | c …]` rows (the initial memory at step 0), `prev_width` apart.
    prev: &'a [f32],
    prev_width: usize,
    /// This step's `[h | c | g]` rows and their gradients (n, 6H).
    res: &'a [f32],
    grad: &'a [f32],
    /// The gradients reaching `h` and `c` from the next step (n, H).
    dh_carry: &'a [f32],
    dc_carry: &'a [f32],
}

crate::multiversion! {
    /// One step's gate gradients `dg` (n, 4H), the masked previous `h` (n, H) for
    /// `dW_hh`, and the gradient `dc_prev` (n, H) passed to the previous step's cell state.
    fn step_backward(
        x: StepRows<'_>,
        dg_all: &mut [f32],
        h_prev: &mut [f32],
        h: usize,
        dc_prev: &mut [f32],
    ) {
        let (h4, width) = (4 * h, 6 * h);
        for (j, &keep) in x.keep.iter().enumerate() {
            let hp = &x.prev[j * x.prev_width..j * x.prev_width + h];
            let cp = &x.prev[j * x.prev_width + h..j * x.prev_width + 2 * h];
            let g = &x.res[j * width + 2 * h..(j + 1) * width];
            let c_new = &x.res[j * width + h..j * width + 2 * h];
            let d = &x.grad[j * width..j * width + 2 * h];
            let dg = &mut dg_all[j * h4..(j + 1) * h4];
            for k in 0..h {
                h_prev[j * h + k] = keep * hp[k];
                let (i, f, gg, o) = gate_activations(g, h, k);
                let tc = tanh_fast(c_new[k]);
                let dh = d[k] + x.dh_carry[j * h + k];
                let dc = d[h + k] + x.dc_carry[j * h + k] + dh * o * (1.0 - tc * tc);
                dg[k] = dc * gg * i * (1.0 - i);
                dg[h + k] = dc * keep * cp[k] * f * (1.0 - f);
                dg[2 * h + k] = dc * i * (1.0 - gg * gg);
                dg[3 * h + k] = dh * tc * o * (1.0 - o);
                dc_prev[j * h + k] = keep * dc * f;
            }
        }
    }
}

impl CustomOp3 for LstmSequence {
    fn name(&self) -> &'static str {
        "lstm-sequence"
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
        let (tn, h4) = l1.shape().dims2()?;
        let h = h4 / 4;
        let n = self.n;
        if h4 != 4 * h
            || l2.shape().dims2()? != (h4, h)
            || l3.shape().dims2()? != (n, 2 * h)
            || n == 0
            || tn % n != 0
            || self.keep.len() != tn
        {
            return Err(candle_core::Error::Msg(format!(
                "lstm sequence: shapes {:?}, {:?}, {:?} do not fit (T·{n}, 4H), (4H, H), ({n}, 2H)",
                l1.shape(),
                l2.shape(),
                l3.shape()
            )));
        }
        let gx = slice(s1, l1, "lstm sequence: gx")?;
        let w = Recurrent::new(
            slice(s2, l2, "lstm sequence: W_hh")?,
            self.w_hh_t.as_ref(),
            h4,
            h,
            n,
        )?;
        let hc0 = slice(s3, l3, "lstm sequence: memory")?;
        let width = 6 * h;
        let mut out = vec![0f32; tn * width];
        let mut hm = vec![0f32; n * h];
        let mut cm = vec![0f32; n * h];
        for t in 0..tn / n {
            for j in 0..n {
                let keep = self.keep[t * n + j];
                let (hp, cp) = if t == 0 {
                    (
                        &hc0[j * 2 * h..j * 2 * h + h],
                        &hc0[j * 2 * h + h..(j + 1) * 2 * h],
                    )
                } else {
                    let r = ((t - 1) * n + j) * width;
                    (&out[r..r + h], &out[r + h..r + 2 * h])
                };
                for k in 0..h {
                    hm[j * h + k] = keep * hp[k];
                    cm[j * h + k] = keep * cp[k];
                }
            }
            let rec = w.times(&hm, n)?;
            step_forward(
                &gx[t * n * h4..(t + 1) * n * h4],
                &rec,
                &cm,
                h,
                &mut out[t * n * width..(t + 1) * n * width],
            );
        }
        Ok((CpuStorage::F32(out), Shape::from((tn, width))))
    }

    fn bwd(
        &self,
        _gx: &Tensor,
        w: &Tensor,
        hc0: &Tensor,
        res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        let (tn, width) = res.dims2()?;
        let (h, n) = (width / 6, self.n);
        let h4 = 4 * h;
        // Read in place (the output and its gradient are 6H wide: copies would cost more
        // than the gate arithmetic).
        let (res, grad, hc0) = (res.contiguous()?, grad.contiguous()?, hc0.contiguous()?);
        let (res_s, res_l) = res.storage_and_layout();
        let (grad_s, grad_l) = grad.storage_and_layout();
        let (hc0_s, hc0_l) = hc0.storage_and_layout();
        let res = cpu_f32(&res_s, res_l, "lstm sequence: output")?;
        let grad = cpu_f32(&grad_s, grad_l, "lstm sequence: gradient")?;
        let hc0 = cpu_f32(&hc0_s, hc0_l, "lstm sequence: memory")?;
        let w = w.contiguous()?;
        let mut dg_all = vec![0f32; tn * h4];
        // The previous steps' masked h, the right operand of dW_hh = Σ_t dg_tᵀ h_{t−1}.
        let mut h_prev = vec![0f32; tn * h];
        let mut dh_carry = vec![0f32; n * h];
        let mut dc_carry = vec![0f32; n * h];
        let mut dc_prev = vec![0f32; n * h];
        for t in (0..tn / n).rev() {
            let (prev, prev_width) = if t == 0 {
                (hc0, 2 * h)
            } else {
                (&res[(t - 1) * n * width..t * n * width], width)
            };
            step_backward(
                StepRows {
                    keep: &self.keep[t * n..(t + 1) * n],
                    prev,
                    prev_width,
                    res: &res[t * n * width..(t + 1) * n * width],
                    grad: &grad[t * n * width..(t + 1) * n * width],
                    dh_carry: &dh_carry,
                    dc_carry: &dc_carry,
                },
                &mut dg_all[t * n * h4..(t + 1) * n * h4],
                &mut h_prev[t * n * h..(t + 1) * n * h],
                h,
                &mut dc_prev,
            );
            let dg_t =
                Tensor::from_slice(&dg_all[t * n * h4..(t + 1) * n * h4], (n, h4), &Device::Cpu)?;
            let dhm: Vec<f32> = dg_t.matmul(&w)?.flatten_all()?.to_vec1()?;
            for j in 0..n {
                let keep = self.keep[t * n + j];
                for k in 0..h {
                    dh_carry[j * h + k] = keep * dhm[j * h + k];
                }
            }
            dc_carry.copy_from_slice(&dc_prev);
        }
        let dg = Tensor::from_vec(dg_all, (tn, h4), &Device::Cpu)?;
        let dw = dg
            .t()?
            .matmul(&Tensor::from_vec(h_prev, (tn, h), &Device::Cpu)?)?;
        let mut dhc0 = vec![0f32; n * 2 * h];
        for j in 0..n {
            dhc0[j * 2 * h..j * 2 * h + h].copy_from_slice(&dh_carry[j * h..(j + 1) * h]);
            dhc0[j * 2 * h + h..(j + 1) * 2 * h].copy_from_slice(&dc_carry[j * h..(j + 1) * h]);
        }
        Ok((
            Some(dg),
            Some(dw),
            Some(Tensor::from_vec(dhc0, (n, 2 * h), &Device::Cpu)?),
        ))
    }
}

/// Runs T LSTM steps of n sequences: `gx` (T·n, 4H) the projected inputs with both biases,
/// t-major; `w_hh` (4H, H); `h0`, `c0` (n, H); `keep` (T, n), 0 where step t starts an
/// episode (the memory is zeroed before that step). Returns `[h | c | g]` per frame
/// (T·n, 6H): the new memory and the gate pre-activations. `w_hh_t`, where the caller keeps
/// one, is `W_hhᵀ` (H, 4H) contiguous with `w_hh`'s values (it saves a transpose per call).
pub fn lstm_sequence(
    gx: &Tensor,
    w_hh: &Tensor,
    w_hh_t: Option<&Tensor>,
    h0: &Tensor,
    c0: &Tensor,
    keep: &Tensor,
) -> Result<Tensor> {
    let n = keep.dim(1)?;
    let keep: Vec<f32> = keep.flatten_all()?.to_vec1()?;
    let hc0 = Tensor::cat(&[h0, c0], 1)?;
    gx.contiguous()?.apply_op3(
        &w_hh.contiguous()?,
        &hc0,
        LstmSequence {
            keep: keep.into(),
            n,
            w_hh_t: w_hh_t.cloned(),
        },
    )
}

#[cfg(test)]
mod tests {
    use crate::policy::kernels::tanh_fast;

    #[test]
    fn fast_tanh_is_within_a_few_ulp() {
        let mut worst = 0f64;
        for i in -200_000..=200_000 {
            let x = i as f32 * 1e-4; // −20 … 20, the tiny-x branch included
            let exact = f64::from(x).tanh();
            let err = (f64::from(tanh_fast(x)) - exact).abs();
            worst = worst.max(err / exact.abs().max(1e-3));
        }
        assert!(worst < 1e-6, "largest relative error {worst}");
        // Saturated within 2 ulp of ±1, and odd.
        assert!((tanh_fast(50.0) - 1.0).abs() <= 2.5e-7);
        assert_eq!(tanh_fast(-50.0), -tanh_fast(50.0));
        assert_eq!(tanh_fast(0.0), 0.0);
    }
}
