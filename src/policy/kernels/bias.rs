//! Adding biases to a batch of rows as one op (issue #16). Candle's `broadcast_add` costs a
//! `sum_keepdim` over the batch in backward, which on the LSTM's (T·n, 4H) input projection
//! was 8% of a 2048-frame update; here the bias gradient is one pass of row additions and the
//! input's gradient is the output's, passed on without a copy.

use candle_core::{CpuStorage, CustomOp2, CustomOp3, Layout, Result, Shape, Tensor};

use super::{cpu_f32, f32_slice};

/// `(x + b1) + b2` for `x` (R, C) and biases (C,), in that order, so the sum rounds exactly as
/// two `broadcast_add`s do.
struct TwoBiases;

impl CustomOp3 for TwoBiases {
    fn name(&self) -> &'static str {
        "two-biases"
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
        let (rows, cols) = l1.shape().dims2()?;
        let x = f32_slice(s1, l1, "bias add: input")?;
        let b1 = f32_slice(s2, l2, "bias add: first bias")?;
        let b2 = f32_slice(s3, l3, "bias add: second bias")?;
        if b1.len() != cols || b2.len() != cols {
            return Err(candle_core::Error::Msg(format!(
                "bias add: biases of {} and {} values for rows of {cols}",
                b1.len(),
                b2.len()
            )));
        }
        let mut out = Vec::with_capacity(rows * cols);
        for row in x.chunks_exact(cols) {
            out.extend(
                row.iter()
                    .zip(b1.iter().zip(b2))
                    .map(|(&v, (&p, &q))| (v + p) + q),
            );
        }
        Ok((CpuStorage::F32(out), Shape::from((rows, cols))))
    }

    fn bwd(
        &self,
        _x: &Tensor,
        _b1: &Tensor,
        _b2: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>, Option<Tensor>)> {
        let db = column_sums(grad)?;
        Ok((Some(grad.clone()), Some(db.clone()), Some(db)))
    }
}

/// `(x + b1) + b2` with `x` (R, C) and the biases (C,) broadcast over the rows; the same values
/// as `x.broadcast_add(b1)?.broadcast_add(b2)?`, with a backward that sums the gradient's rows
/// once for both biases.
pub fn add_two_biases(x: &Tensor, b1: &Tensor, b2: &Tensor) -> Result<Tensor> {
    x.contiguous()?
        .apply_op3(&b1.contiguous()?, &b2.contiguous()?, TwoBiases)
}

/// `x + b` for `x` (R, C) and a bias (C,) broadcast over the rows: the same values as
/// `x.broadcast_add(b)`, whose backward sums the gradient over the rows through candle's
/// reduction over a leading dimension, at a few nanoseconds an element (the heads' biases and
/// the GRU's input bias were 5% of a 128-frame minibatch); [`column_sums`] is one pass.
struct Bias;

impl CustomOp2 for Bias {
    fn name(&self) -> &'static str {
        "bias"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let (rows, cols) = l1.shape().dims2()?;
        let x = f32_slice(s1, l1, "bias add: input")?;
        let b = f32_slice(s2, l2, "bias add: bias")?;
        if b.len() != cols {
            return Err(candle_core::Error::Msg(format!(
                "bias add: a bias of {} values for rows of {cols}",
                b.len()
            )));
        }
        let mut out = Vec::with_capacity(rows * cols);
        for row in x.chunks_exact(cols) {
            out.extend(row.iter().zip(b).map(|(&v, &p)| v + p));
        }
        Ok((CpuStorage::F32(out), Shape::from((rows, cols))))
    }

    fn bwd(
        &self,
        _x: &Tensor,
        _b: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>)> {
        Ok((Some(grad.clone()), Some(column_sums(grad)?)))
    }
}

/// `x + b` with `x` (R, C) and the bias (C,) broadcast over the rows; the same values as
/// `x.broadcast_add(b)`, with a backward that sums the gradient's rows in one pass.
pub fn add_bias(x: &Tensor, b: &Tensor) -> Result<Tensor> {
    x.contiguous()?.apply_op2(&b.contiguous()?, Bias)
}

/// The column sums (C,) of `grad` (R, C), row after row: a bias's gradient, in the order
/// candle's `sum_keepdim(0)` adds (the same bits).
pub(crate) fn column_sums(grad: &Tensor) -> Result<Tensor> {
    let cols = grad.dim(1)?;
    let g = grad.contiguous()?;
    let (storage, layout) = g.storage_and_layout();
    let d = cpu_f32(&storage, layout, "bias add: gradient")?;
    let sum = column_sums_of(d, cols);
    drop(storage);
    Tensor::from_vec(sum, cols, grad.device())
}

/// [`column_sums`] of a row-major slice with rows of `cols` values.
pub(crate) fn column_sums_of(d: &[f32], cols: usize) -> Vec<f32> {
    let mut sum = vec![0f32; cols];
    for row in d.chunks_exact(cols) {
        for (s, &v) in sum.iter_mut().zip(row) {
            *s += v;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::{Device, Var};

    fn bits(t: &Tensor) -> Vec<u32> {
        t.flatten_all()
            .unwrap()
            .to_vec1::<f32>()
            .unwrap()
            .iter()
            .map(|v| v.to_bits())
            .collect()
    }

    /// The bias op gives `broadcast_add`'s values and, through a loss that weighs every output
    /// differently, its gradients for the input and the bias, bit for bit, at the heads' and
    /// the GRU's shapes.
    #[test]
    fn add_bias_is_broadcast_add_bit_for_bit() {
        for (rows, cols) in [(1, 7), (128, 64), (256, 1), (333, 384)] {
            let n = rows * cols;
            let xs: Vec<f32> = (0..n)
                .map(|i| ((i * 37 % 101) as f32 - 50.0) / 7.0)
                .collect();
            let bs: Vec<f32> = (0..cols).map(|i| (i as f32).sin() * 3.0).collect();
            let ws: Vec<f32> = (0..n)
                .map(|i| ((i * 13 % 29) as f32 - 14.0) / 3.0)
                .collect();
            let w = Tensor::from_vec(ws, (rows, cols), &Device::Cpu).unwrap();
            let run = |fused: bool| {
                let x = Var::from_vec(xs.clone(), (rows, cols), &Device::Cpu).unwrap();
                let b = Var::from_vec(bs.clone(), cols, &Device::Cpu).unwrap();
                let y = if fused {
                    add_bias(x.as_tensor(), b.as_tensor()).unwrap()
                } else {
                    x.as_tensor().broadcast_add(b.as_tensor()).unwrap()
                };
                let grads = (&y * &w).unwrap().sum_all().unwrap().backward().unwrap();
                let gx = grads.get(x.as_tensor()).unwrap().clone();
                let gb = grads.get(b.as_tensor()).unwrap().clone();
                (bits(&y), bits(&gx), bits(&gb))
            };
            assert_eq!(run(true), run(false), "({rows}, {cols})");
        }
    }
}
