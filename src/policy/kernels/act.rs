//! `tanh` and the logistic sigmoid as ops with the LSTM's rational approximation (issue #16):
//! for the actor and critic heads and the mission GRU. Candle's `tanh` calls glibc's `tanhf`
//! (through `expm1f`) one element at a time, which was an eighth of a batch-256 inference
//! step; these loops are vectorised (see [`super::simd`]) and their backward is one pass.

use candle_core::{CpuStorage, CustomOp1, CustomOp2, Layout, Result, Shape, Tensor};

use super::f32_slice;
use super::{sigmoid as sigmoid_fast, tanh_fast};

/// Which activation an op computes.
#[derive(Clone, Copy)]
enum Kind {
    Tanh,
    Sigmoid,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Self::Tanh => "fast-tanh",
            Self::Sigmoid => "fast-sigmoid",
        }
    }
}

struct Activation(Kind);

/// Its backward from the output `y` and its gradient: `g·(1 − y²)` or `g·y·(1 − y)`.
struct ActivationBackward(Kind);

crate::multiversion! {
    fn tanh_all(x: &[f32], out: &mut [f32]) {
        for (o, v) in out.iter_mut().zip(x) {
            *o = tanh_fast(*v);
        }
    }
}

crate::multiversion! {
    fn sigmoid_all(x: &[f32], out: &mut [f32]) {
        for (o, v) in out.iter_mut().zip(x) {
            *o = sigmoid_fast(*v);
        }
    }
}

crate::multiversion! {
    fn tanh_grad(y: &[f32], g: &[f32], out: &mut [f32]) {
        for ((o, y), g) in out.iter_mut().zip(y).zip(g) {
            *o = g * (1.0 - y * y);
        }
    }
}

crate::multiversion! {
    fn sigmoid_grad(y: &[f32], g: &[f32], out: &mut [f32]) {
        for ((o, y), g) in out.iter_mut().zip(y).zip(g) {
            *o = g * y * (1.0 - y);
        }
    }
}

impl CustomOp1 for Activation {
    fn name(&self) -> &'static str {
        self.0.name()
    }

    fn cpu_fwd(&self, s: &CpuStorage, l: &Layout) -> Result<(CpuStorage, Shape)> {
        let x = f32_slice(s, l, self.0.name())?;
        let mut out = vec![0f32; x.len()];
        match self.0 {
            Kind::Tanh => tanh_all(x, &mut out),
            Kind::Sigmoid => sigmoid_all(x, &mut out),
        }
        Ok((CpuStorage::F32(out), l.shape().clone()))
    }

    fn bwd(&self, _arg: &Tensor, res: &Tensor, grad: &Tensor) -> Result<Option<Tensor>> {
        Ok(Some(res.contiguous()?.apply_op2_no_bwd(
            &grad.contiguous()?,
            &ActivationBackward(self.0),
        )?))
    }
}

impl CustomOp2 for ActivationBackward {
    fn name(&self) -> &'static str {
        "fast-activation-backward"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let y = f32_slice(s1, l1, "activation backward: output")?;
        let g = f32_slice(s2, l2, "activation backward: gradient")?;
        if y.len() != g.len() {
            return Err(candle_core::Error::Msg(format!(
                "activation backward: output {:?} and gradient {:?} differ",
                l1.shape(),
                l2.shape()
            )));
        }
        let mut out = vec![0f32; y.len()];
        match self.0 {
            Kind::Tanh => tanh_grad(y, g, &mut out),
            Kind::Sigmoid => sigmoid_grad(y, g, &mut out),
        }
        Ok((CpuStorage::F32(out), l1.shape().clone()))
    }
}

/// `tanh(x)` element-wise (the LSTM's rational approximation), with its backward.
pub fn tanh(x: &Tensor) -> Result<Tensor> {
    x.contiguous()?.apply_op1(Activation(Kind::Tanh))
}

/// `1 / (1 + e^−x)` element-wise, as `0.5·tanh(x/2) + 0.5` with the same approximation, with
/// its backward.
pub fn sigmoid(x: &Tensor) -> Result<Tensor> {
    x.contiguous()?.apply_op1(Activation(Kind::Sigmoid))
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::{Device, Var};

    #[test]
    fn values_and_gradients_match_candles_exact_activations() {
        let v: Vec<f32> = (0..301).map(|i| (i as f32 - 150.0) * 0.07).collect();
        let x = Var::from_vec(v, (7, 43), &Device::Cpu).unwrap();
        let w = Tensor::from_vec(
            (0..301)
                .map(|i| ((i * 37) % 11) as f32 - 5.0)
                .collect::<Vec<f32>>(),
            (7, 43),
            &Device::Cpu,
        )
        .unwrap();
        let pairs: [(Tensor, Tensor); 2] = [
            (tanh(x.as_tensor()).unwrap(), x.as_tensor().tanh().unwrap()),
            (
                sigmoid(x.as_tensor()).unwrap(),
                candle_nn::ops::sigmoid(x.as_tensor()).unwrap(),
            ),
        ];
        for (fast, exact) in pairs {
            let diff = (&fast - &exact).unwrap().abs().unwrap().max_all().unwrap();
            assert!(diff.to_scalar::<f32>().unwrap() < 1e-6);
            let gf = (&fast * &w).unwrap().sum_all().unwrap().backward().unwrap();
            let ge = (&exact * &w)
                .unwrap()
                .sum_all()
                .unwrap()
                .backward()
                .unwrap();
            let (gf, ge) = (gf.get(&x).unwrap(), ge.get(&x).unwrap());
            let diff = (gf - ge).unwrap().abs().unwrap().max_all().unwrap();
            assert!(diff.to_scalar::<f32>().unwrap() < 1e-5);
        }
    }
}
