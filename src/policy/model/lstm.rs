//! The network's LSTM: the input projection, one step (fused gates, and candle's own ops as
//! their reference) and a chunk of steps as one fused op. PyTorch's equations and gate order
//! (i, f, g, o).

use candle_core::Tensor;

use super::{Memory, Net};
use crate::policy::error::PolicyError;

impl Net {
    /// The LSTM input projection for all frames at once: `x W_ihᵀ + b_ih`, (B, 4H).
    pub fn lstm_input(&self, x: &Tensor) -> Result<Tensor, PolicyError> {
        let lstm = &self.weights.lstm;
        Ok(Self::times_t(x, &lstm.w_ih)?.broadcast_add(&lstm.b_ih)?)
    }

    /// The gate pre-activations of an LSTM step: `gx + h W_hhᵀ + b_hh`, (B, 4H).
    pub(super) fn lstm_preactivations(
        &self,
        gx: &Tensor,
        mem: &Memory,
    ) -> Result<Tensor, PolicyError> {
        let lstm = &self.weights.lstm;
        Ok((gx + Self::times_t(&mem.h, &lstm.w_hh)?.broadcast_add(&lstm.b_hh)?)?)
    }

    /// One LSTM step from the projected input `gx` (B, 4H); the gates run as one fused op
    /// with a hand-written backward ([`crate::policy::kernels::lstm::lstm_gates`]).
    pub fn lstm_cell(&self, gx: &Tensor, mem: &Memory) -> Result<Memory, PolicyError> {
        let g = self.lstm_preactivations(gx, mem)?;
        let (h, c) = crate::policy::kernels::lstm::lstm_gates(&g, &mem.c)?;
        Ok(Memory { h, c })
    }

    /// [`Self::lstm_cell`] built from candle's own ops and autograd: the reference the fused
    /// gates are tested against.
    pub fn lstm_cell_reference(&self, gx: &Tensor, mem: &Memory) -> Result<Memory, PolicyError> {
        let hd = self.cfg.lstm_hidden;
        let g = self.lstm_preactivations(gx, mem)?;
        let ifo = candle_nn::ops::sigmoid(&g)?;
        let i = ifo.narrow(1, 0, hd)?;
        let f = ifo.narrow(1, hd, hd)?;
        let o = ifo.narrow(1, 3 * hd, hd)?;
        let gg = g.narrow(1, 2 * hd, hd)?.tanh()?;
        let c = ((f * &mem.c)? + (i * gg)?)?;
        let h = (o * c.tanh()?)?;
        Ok(Memory { h, c })
    }

    /// The LSTM over a chunk of T steps of n sequences (t-major rows of `x`, `keep` (T, n)) as
    /// one fused op ([`crate::policy::kernels::sequence`]): every step's `h` (T·n, H) with gradient, and
    /// the memory after each step.
    pub(super) fn lstm_chunk(
        &self,
        x: &Tensor,
        mem0: &Memory,
        keep: &Tensor,
    ) -> Result<(Tensor, Vec<Memory>), PolicyError> {
        let (t_len, n) = keep.dims2()?;
        let hd = self.cfg.lstm_hidden;
        // The same sums as `lstm_input(x) + b_hh`, with one pass over the rows in backward.
        let lstm = &self.weights.lstm;
        let gx = crate::policy::kernels::bias::add_two_biases(
            &Self::times_t(x, &lstm.w_ih)?,
            &lstm.b_ih,
            &lstm.b_hh,
        )?;
        let out = crate::policy::kernels::sequence::lstm_sequence(
            &gx,
            &lstm.w_hh.w,
            lstm.w_hh.wt.as_ref(),
            &mem0.h,
            &mem0.c,
            keep,
        )?;
        let mems = (0..t_len)
            .map(|t| {
                let rows = out.narrow(0, t * n, n)?;
                Ok(Memory {
                    h: rows.narrow(1, 0, hd)?,
                    c: rows.narrow(1, hd, hd)?,
                })
            })
            .collect::<Result<Vec<_>, PolicyError>>()?;
        Ok((out.narrow(1, 0, hd)?, mems))
    }
}
