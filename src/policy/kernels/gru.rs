//! The mission GRU over all its words as one op. Word by word, candle's autograd recorded
//! about fifteen ops per word and twice as many in backward, each on a few (missions × 128)
//! values, and every shard of a `train --threads` minibatch paid them again: the words after
//! the first were 7–10% of a one-thread training run. Here the forward runs the words on the
//! host with the same operations in the same order as the composite
//! [`crate::policy::model::Net::encode_text_reference`] (so the same bits, which
//! `tests/it/policy/fused.rs` checks), and a hand-written backward through the words returns the
//! gradients of the projected inputs, `W_hh` and `b_hh` at once.

use std::sync::Arc;

use candle_core::{CpuStorage, CustomOp3, Device, Layout, Result, Shape, Tensor};

use super::sequence::Recurrent;
use super::{cpu_f32, f32_slice as slice, sigmoid, tanh_fast};

/// The op: inputs `gx` (U, L, 3H) with `b_ih` included, `W_hh` (3H, H) and `b_hh` (3H);
/// output per word and mission `[h | r | z | n | ghₙ]` (L·U, 5H), word-major, kept for the
/// backward (`h` after the padding mask).
struct GruSequence {
    /// (L·U) word-major: 1 for a word, 0 for padding (the state carries over).
    valid: Arc<[f32]>,
    u: usize,
    l: usize,
    /// `W_hhᵀ` made contiguous by the caller (an acting net keeps one), if any.
    w_hh_t: Option<Tensor>,
}

/// One word's shape: its missions' valid flags (U), the state size H, and the distance
/// between two missions' rows of the projected inputs (L·3H).
#[derive(Clone, Copy)]
struct Word<'a> {
    valid: &'a [f32],
    h: usize,
    stride: usize,
}

crate::multiversion! {
    /// One word's gates for its U rows, from the projected inputs `gx` (U rows of 3H,
    /// `w.stride` apart), the recurrent product `rec` (U, 3H), `b_hh` and the previous state
    /// `hp` (U, H), written into the word's `[h | r | z | n | ghₙ]` rows: the composite's
    /// operations in its order.
    fn word_forward(w: Word<'_>, gx: &[f32], rec: &[f32], b: &[f32], hp: &[f32], out: &mut [f32]) {
        let Word { valid, h, stride } = w;
        let (h3, width) = (3 * h, 5 * h);
        for (j, &v) in valid.iter().enumerate() {
            let gx = &gx[j * stride..j * stride + h3];
            let rec = &rec[j * h3..(j + 1) * h3];
            let hp = &hp[j * h..(j + 1) * h];
            let row = &mut out[j * width..(j + 1) * width];
            for k in 0..h {
                let gh_r = rec[k] + b[k];
                let gh_z = rec[h + k] + b[h + k];
                let gh_n = rec[2 * h + k] + b[2 * h + k];
                let r = sigmoid(gx[k] + gh_r);
                let z = sigmoid(gx[h + k] + gh_z);
                let n = tanh_fast(gx[2 * h + k] + r * gh_n);
                let h_new = n + z * (hp[k] - n);
                row[k] = hp[k] + (h_new - hp[k]) * v;
                row[h + k] = r;
                row[2 * h + k] = z;
                row[3 * h + k] = n;
                row[4 * h + k] = gh_n;
            }
        }
    }
}

crate::multiversion! {
    /// One word's backward for its U rows: from `dh` (U, H), the gradient reaching the word's
    /// output state, the gate gradients `dgh` (U, 3H, of `gh = hp·W_hhᵀ + b_hh`) and `dgx`
    /// (U rows of 3H, `w.stride` apart), and the direct part of the previous state's gradient
    /// `dhp` (U, H; the path through `W_hh` is added by the caller).
    fn word_backward(
        w: Word<'_>,
        res: &[f32],
        hp: &[f32],
        dh: &[f32],
        dgh: &mut [f32],
        dgx: &mut [f32],
        dhp: &mut [f32],
    ) {
        let Word { valid, h, stride } = w;
        let (h3, width) = (3 * h, 5 * h);
        for (j, &v) in valid.iter().enumerate() {
            let row = &res[j * width..(j + 1) * width];
            for k in 0..h {
                let (r, z, n, gh_n) = (row[h + k], row[2 * h + k], row[3 * h + k], row[4 * h + k]);
                let hpk = hp[j * h + k];
                let d = dh[j * h + k];
                let d_new = d * v;
                let dn = d_new * (1.0 - z);
                let dz = d_new * (hpk - n);
                let da_n = dn * (1.0 - n * n);
                let dr = da_n * gh_n;
                let da_z = dz * z * (1.0 - z);
                let da_r = dr * r * (1.0 - r);
                dhp[j * h + k] = d * (1.0 - v) + d_new * z;
                let g = &mut dgh[j * h3..(j + 1) * h3];
                g[k] = da_r;
                g[h + k] = da_z;
                g[2 * h + k] = da_n * r;
                let x = &mut dgx[j * stride..j * stride + h3];
                x[k] = da_r;
                x[h + k] = da_z;
                x[2 * h + k] = da_n;
            }
        }
    }
}

impl GruSequence {
    /// Word `t`'s shape for state size `h`: its missions' valid flags and the rows' stride.
    fn word(&self, t: usize, h: usize) -> Word<'_> {
        Word {
            valid: &self.valid[t * self.u..(t + 1) * self.u],
            h,
            stride: self.l * 3 * h,
        }
    }
}

impl CustomOp3 for GruSequence {
    fn name(&self) -> &'static str {
        "gru-sequence"
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
        let (u, l) = (self.u, self.l);
        let (_, _, h3) = l1.shape().dims3()?;
        let h = h3 / 3;
        if l1.shape().dims3()? != (u, l, h3)
            || h3 != 3 * h
            || l2.shape().dims2()? != (h3, h)
            || l3.shape().dims1()? != h3
            || self.valid.len() != u * l
        {
            return Err(candle_core::Error::Msg(format!(
                "gru sequence: shapes {:?}, {:?}, {:?} do not fit ({u}, {l}, 3H), (3H, H), (3H)",
                l1.shape(),
                l2.shape(),
                l3.shape()
            )));
        }
        let gx = slice(s1, l1, "gru sequence: gx")?;
        let w = Recurrent::new(
            slice(s2, l2, "gru sequence: W_hh")?,
            self.w_hh_t.as_ref(),
            h3,
            h,
            u,
        )?;
        let b = slice(s3, l3, "gru sequence: b_hh")?;
        let width = 5 * h;
        let mut out = vec![0f32; l * u * width];
        let mut hp = vec![0f32; u * h];
        for t in 0..l {
            let rec = w.times(&hp, u)?;
            let word = self.word(t, h);
            word_forward(
                word,
                &gx[t * h3..],
                &rec,
                b,
                &hp,
                &mut out[t * u * width..(t + 1) * u * width],
            );
            for j in 0..u {
                let row = (t * u + j) * width;
                hp[j * h..(j + 1) * h].copy_from_slice(&out[row..row + h]);
            }
        }
        Ok((CpuStorage::F32(out), Shape::from((l * u, width))))
    }

    fn bwd(
        &self,
        _gx: &Tensor,
        w: &Tensor,
        _b: &Tensor,
        res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        let (u, l) = (self.u, self.l);
        let (_, width) = res.dims2()?;
        let h = width / 5;
        let h3 = 3 * h;
        let (res, grad) = (res.contiguous()?, grad.contiguous()?);
        let (res_s, res_l) = res.storage_and_layout();
        let (grad_s, grad_l) = grad.storage_and_layout();
        let res = cpu_f32(&res_s, res_l, "gru sequence: output")?;
        let grad = cpu_f32(&grad_s, grad_l, "gru sequence: gradient")?;
        let w = w.contiguous()?;
        let mut dgx = vec![0f32; u * l * h3];
        // Every word's gate gradients and previous states: dW_hh = Σ_t dghₜᵀ hₜ₋₁.
        let mut dgh_all = vec![0f32; l * u * h3];
        let mut hp_all = vec![0f32; l * u * h];
        let mut dh = vec![0f32; u * h];
        let mut dhp = vec![0f32; u * h];
        for t in (0..l).rev() {
            for j in 0..u {
                let row = (t * u + j) * width;
                for k in 0..h {
                    dh[j * h + k] += grad[row + k];
                }
                if t > 0 {
                    let prev = ((t - 1) * u + j) * width;
                    hp_all[(t * u + j) * h..(t * u + j + 1) * h]
                        .copy_from_slice(&res[prev..prev + h]);
                }
            }
            let word = self.word(t, h);
            word_backward(
                word,
                &res[t * u * width..(t + 1) * u * width],
                &hp_all[t * u * h..(t + 1) * u * h],
                &dh,
                &mut dgh_all[t * u * h3..(t + 1) * u * h3],
                &mut dgx[t * h3..],
                &mut dhp,
            );
            let dgh = Tensor::from_slice(
                &dgh_all[t * u * h3..(t + 1) * u * h3],
                (u, h3),
                &Device::Cpu,
            )?;
            let through: Vec<f32> = dgh.matmul(&w)?.flatten_all()?.to_vec1()?;
            for ((d, p), r) in dh.iter_mut().zip(&dhp).zip(&through) {
                *d = p + r;
            }
        }
        let db = Tensor::from_vec(super::bias::column_sums_of(&dgh_all, h3), h3, &Device::Cpu)?;
        let dgh = Tensor::from_vec(dgh_all, (l * u, h3), &Device::Cpu)?;
        let dw = dgh
            .t()?
            .matmul(&Tensor::from_vec(hp_all, (l * u, h), &Device::Cpu)?)?;
        Ok((
            Some(Tensor::from_vec(dgx, (u, l, h3), &Device::Cpu)?),
            Some(dw),
            Some(db),
        ))
    }
}

/// The GRU's final state (U, H) over L words of U missions from a zero state: `gx` (U, L, 3H)
/// the projected words with `b_ih`, `w_hh` (3H, H), `b_hh` (3H), `valid` (U, L) 1 for a word
/// and 0 for padding (the state carries over). `w_hh_t`, where the caller keeps one, is
/// `W_hhᵀ` contiguous.
pub fn gru_sequence(
    gx: &Tensor,
    w_hh: &Tensor,
    w_hh_t: Option<&Tensor>,
    b_hh: &Tensor,
    valid: &Tensor,
) -> Result<Tensor> {
    let (u, l) = valid.dims2()?;
    let h = w_hh.dim(1)?;
    if l == 0 || u == 0 {
        return Tensor::zeros((u, h), candle_core::DType::F32, &Device::Cpu);
    }
    // Word-major, so that each word's flags are one slice.
    let valid: Vec<f32> = valid.t()?.flatten_all()?.to_vec1()?;
    let out = gx.contiguous()?.apply_op3(
        &w_hh.contiguous()?,
        &b_hh.contiguous()?,
        GruSequence {
            valid: valid.into(),
            u,
            l,
            w_hh_t: w_hh_t.cloned(),
        },
    )?;
    out.narrow(0, (l - 1) * u, u)?.narrow(1, 0, h)?.contiguous()
}
