//! The element-wise part of one LSTM step (the acting path's gates) as one op with a
//! hand-written backward; [`crate::policy::model::Net::lstm_cell_reference`] is its
//! composite reference.

use candle_core::{CpuStorage, CustomOp2, CustomOp3, Layout, Result, Shape, Tensor};

// The same activations as the training path's LSTM op, so that acting (evaluation, replays,
// the debugger) computes what the rollouts trained on; glibc's `tanhf`/`expf` were also a
// fifth of a batch-256 inference step.
use super::{f32_slice, gate_activations, tanh_fast};

/// The element-wise part of one LSTM step, PyTorch's gate order (i, f, g, o): from the gate
/// pre-activations `g` (B, 4H) and the previous cell state `c` (B, H), the new `[h, c]` as one
/// (B, 2H) tensor.
pub struct LstmGates;

/// Its backward: from `g`, `c` and the gradient of `[h, c]`, the gradients `[dg, dc]` as one
/// (B, 5H) tensor.
struct LstmGatesBackward;

fn dims(l1: &Layout, l2: &Layout) -> Result<(usize, usize)> {
    let (b, h4) = l1.shape().dims2()?;
    let (b2, h) = l2.shape().dims2()?;
    if b != b2 || h4 != 4 * h {
        return Err(candle_core::Error::Msg(format!(
            "lstm gates: shapes {:?} and {:?} do not fit (B, 4H) and (B, H)",
            l1.shape(),
            l2.shape()
        )));
    }
    Ok((b, h))
}

impl CustomOp2 for LstmGates {
    fn name(&self) -> &'static str {
        "lstm-gates"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let (b, h) = dims(l1, l2)?;
        let (g, c) = (
            f32_slice(s1, l1, "lstm gates: g")?,
            f32_slice(s2, l2, "lstm gates: c")?,
        );
        let mut out = vec![0f32; b * 2 * h];
        gates_forward(g, c, h, &mut out);
        Ok((CpuStorage::F32(out), Shape::from((b, 2 * h))))
    }

    fn bwd(
        &self,
        g: &Tensor,
        c: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>)> {
        let h = c.dim(1)?;
        let both = g.contiguous()?.apply_op3_no_bwd(
            &c.contiguous()?,
            &grad.contiguous()?,
            &LstmGatesBackward,
        )?;
        Ok((
            Some(both.narrow(1, 0, 4 * h)?),
            Some(both.narrow(1, 4 * h, h)?),
        ))
    }
}

impl CustomOp3 for LstmGatesBackward {
    fn name(&self) -> &'static str {
        "lstm-gates-backward"
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
        let (b, h) = dims(l1, l2)?;
        let (g, c) = (
            f32_slice(s1, l1, "lstm gates: g")?,
            f32_slice(s2, l2, "lstm gates: c")?,
        );
        let d = f32_slice(s3, l3, "lstm gates: gradient")?;
        if d.len() != b * 2 * h {
            return Err(candle_core::Error::Msg(
                "lstm gates: the gradient is not (B, 2H)".into(),
            ));
        }
        let mut out = vec![0f32; b * 5 * h];
        gates_backward(g, c, d, h, &mut out);
        Ok((CpuStorage::F32(out), Shape::from((b, 5 * h))))
    }
}

crate::multiversion! {
    /// [`LstmGates`]' loop: rows of `g` (B, 4H) and `c` (B, H) into `[h, c]` rows of `out`.
    fn gates_forward(g: &[f32], c: &[f32], h: usize, out: &mut [f32]) {
        for r in 0..c.len().checked_div(h).unwrap_or(0) {
            let gr = &g[r * 4 * h..(r + 1) * 4 * h];
            let cr = &c[r * h..(r + 1) * h];
            let (oh, oc) = out[r * 2 * h..(r + 1) * 2 * h].split_at_mut(h);
            for k in 0..h {
                let (i, f, gg, o) = gate_activations(gr, h, k);
                let cn = f * cr[k] + i * gg;
                oc[k] = cn;
                oh[k] = o * tanh_fast(cn);
            }
        }
    }
}

crate::multiversion! {
    /// [`LstmGatesBackward`]' loop: `[dg, dc]` rows of `out` from `g`, `c` and `d` (B, 2H).
    fn gates_backward(g: &[f32], c: &[f32], d: &[f32], h: usize, out: &mut [f32]) {
        for r in 0..c.len().checked_div(h).unwrap_or(0) {
            let gr = &g[r * 4 * h..(r + 1) * 4 * h];
            let cr = &c[r * h..(r + 1) * h];
            let (dh, dc_out) = d[r * 2 * h..(r + 1) * 2 * h].split_at(h);
            let (dg, dc_prev) = out[r * 5 * h..(r + 1) * 5 * h].split_at_mut(4 * h);
            for k in 0..h {
                let (i, f, gg, o) = gate_activations(gr, h, k);
                let cn = f * cr[k] + i * gg;
                let tc = tanh_fast(cn);
                let dc = dc_out[k] + dh[k] * o * (1.0 - tc * tc);
                dg[k] = dc * gg * i * (1.0 - i);
                dg[h + k] = dc * cr[k] * f * (1.0 - f);
                dg[2 * h + k] = dc * i * (1.0 - gg * gg);
                dg[3 * h + k] = dh[k] * tc * o * (1.0 - o);
                dc_prev[k] = dc * f;
            }
        }
    }
}

/// `[h, c]` of an LSTM step from gate pre-activations `g` (B, 4H) and the cell state `c`
/// (B, H), fused, with its backward.
pub fn lstm_gates(g: &Tensor, c: &Tensor) -> Result<(Tensor, Tensor)> {
    let h = c.dim(1)?;
    let both = g.contiguous()?.apply_op2(&c.contiguous()?, LstmGates)?;
    // Contiguous copies: memories are row-selected (`index_select`) and matmul'd downstream.
    Ok((
        both.narrow(1, 0, h)?.contiguous()?,
        both.narrow(1, h, h)?.contiguous()?,
    ))
}
