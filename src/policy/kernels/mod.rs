//! The performance kernels of the network: fused ops with hand-written backward passes, where
//! candle's per-op overhead dominates this model's small tensors (issue #16), and their SIMD
//! dispatch ([`simd`]). Each op has a composite reference built from candle ops in
//! [`super::model`] or [`super::attention`]; `tests/it/policy/fused.rs` compares outputs and
//! gradients. The helpers every kernel shares live here, so the kernels import only this module.

pub mod act;
pub mod attention;
pub mod bias;
pub mod conv;
pub mod gru;
pub mod lstm;
pub mod sequence;
pub mod simd;

use candle_core::{CpuStorage, Layout, Result, Tensor};

/// The f32 values of a contiguous storage; `what` names the op and input in errors.
pub(crate) fn f32_slice<'a>(s: &'a CpuStorage, l: &Layout, what: &str) -> Result<&'a [f32]> {
    let CpuStorage::F32(v) = s else {
        return Err(candle_core::Error::Msg(format!("{what} must be f32")));
    };
    l.contiguous_offsets()
        .map(|(a, b)| &v[a..b])
        .ok_or_else(|| candle_core::Error::Msg(format!("{what} must be contiguous")))
}

/// The f32 values of a contiguous CPU tensor's storage (as `storage_and_layout` gives it).
pub(crate) fn cpu_f32<'a>(
    s: &'a candle_core::Storage,
    l: &Layout,
    what: &str,
) -> Result<&'a [f32]> {
    match s {
        candle_core::Storage::Cpu(c) => f32_slice(c, l, what),
        _ => Err(candle_core::Error::Msg(format!(
            "{what} must be on the CPU"
        ))),
    }
}

/// `tanh` as Eigen's `ptanh_float` computes it: a [13/6] rational approximation on
/// [−7.905, 7.905] (±1 beyond), within a few ulp of the true value. glibc's `tanhf` (through
/// `expm1f`) was the largest single cost of this op. Plain multiply-adds: `mul_add` would
/// call the software `fmaf` on builds without the FMA target feature.
#[inline]
pub fn tanh_fast(x: f32) -> f32 {
    const CLAMP: f32 = 7.905_311;
    const A: [f32; 7] = [
        4.893_524_6e-3,
        6.372_619_3e-4,
        1.485_722_4e-5,
        5.122_297e-8,
        -8.604_672e-11,
        2.000_188e-13,
        -2.760_768_5e-16,
    ];
    const B: [f32; 4] = [4.893_525e-3, 2.268_434_6e-3, 1.185_347_1e-4, 1.198_258_4e-6];
    if x.abs() < 4e-4 {
        return x;
    }
    let x = x.clamp(-CLAMP, CLAMP);
    let x2 = x * x;
    let mut p = A[6];
    for a in A[..6].iter().rev() {
        p = p * x2 + a;
    }
    let mut q = B[3];
    for b in B[..3].iter().rev() {
        q = q * x2 + b;
    }
    x * p / q
}

/// `σ(x) = (1 + tanh(x/2)) / 2`, through [`tanh_fast`].
#[inline]
pub(super) fn sigmoid(x: f32) -> f32 {
    0.5 * tanh_fast(0.5 * x) + 0.5
}

/// The activations of unit `k` from one row of gate pre-activations `g` (4H, PyTorch's order
/// i, f, g, o): `(σ(i), σ(f), tanh(g), σ(o))`, shared by every LSTM loop.
#[expect(
    clippy::inline_always,
    reason = "the loops that call it are compiled per vector unit; a call would keep them scalar"
)]
#[inline(always)]
pub(super) fn gate_activations(g: &[f32], h: usize, k: usize) -> (f32, f32, f32, f32) {
    (
        sigmoid(g[k]),
        sigmoid(g[h + k]),
        tanh_fast(g[2 * h + k]),
        sigmoid(g[3 * h + k]),
    )
}

/// `x · Wᵀ` for a 2-D `x`, by `wt` (`Wᵀ` contiguous, where the caller keeps one) from two rows
/// on: for the [`TRANSPOSED`](crate::policy::model::TRANSPOSED) matrices gemm gives the same bits with either layout
/// (`tests/it/policy/net.rs` checks every row count to 64 and larger ones, and acting and rollout
/// steps bit for bit), while one row takes gemm's matrix-vector path, which rounds differently
/// with the two layouts, so it stays strided.
pub(crate) fn times_transposed(
    x: &Tensor,
    w: &Tensor,
    wt: Option<&Tensor>,
) -> candle_core::Result<Tensor> {
    match wt {
        Some(wt) if x.dim(0)? >= 2 => x.matmul(wt),
        _ => x.matmul(&w.t()?),
    }
}
