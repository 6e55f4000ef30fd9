//! The first layer, `Õ = ReLU(Conv(O) + b)` (3×3, or 1×1 with `conv_kernel` 1), computed
//! from the codes set in each cell instead of the one-hot im2col patches (issue #16). A 3×3
//! patch has 180 entries of which at most 27 are 1, so the dense GEMM did 6.7× the necessary
//! work and built 35 KB of patches per frame; here each output cell adds the ≤ 27 weight
//! columns its codes select (3 for a 1×1 kernel). The backward scatters into the same columns
//! (the input is a constant and needs no gradient). [`crate::policy::model::Net::cells_reference`]
//! keeps the dense version; `tests/it/policy/fused.rs` compares.

use candle_core::{CpuStorage, CustomOp2, Layout, Result, Shape, Tensor};

use super::f32_slice as slice;
use crate::env::view::VIEW_SIZE;
use crate::policy::obs::{CellCodes, N_CELLS, NO_CODE, patch_len};

/// The forward op: inputs the weight (K, patch) and bias (K); output (B, 49, K).
struct ConvCodes {
    codes: CellCodes,
    kernel: usize,
}

/// Its backward: inputs the output `Õ` (B, 49, K) and its gradient; output
/// `[dW (K·patch) | db (K)]` as one vector.
struct ConvCodesBackward {
    codes: CellCodes,
    kernel: usize,
}

/// The patch columns feeding output cell `cell` of a `kernel`×`kernel` convolution (1 or 3),
/// `(column, …)` with `column = c·kernel² + ky·kernel + kx` as in
/// [`crate::policy::obs::patches`], passed to `f` one at a time; an unset slot ([`NO_CODE`]) has none.
#[inline]
fn for_each_column(codes: &[u8], kernel: usize, cell: usize, mut f: impl FnMut(usize)) {
    if kernel == 1 {
        for &c in &codes[cell * 3..cell * 3 + 3] {
            if c != NO_CODE {
                f(usize::from(c));
            }
        }
        return;
    }
    let v = VIEW_SIZE as isize;
    let (ny, nx) = ((cell / VIEW_SIZE) as isize, (cell % VIEW_SIZE) as isize);
    for ky in 0..3isize {
        let vy = ny + ky - 1;
        if !(0..v).contains(&vy) {
            continue;
        }
        for kx in 0..3isize {
            let vx = nx + kx - 1;
            if !(0..v).contains(&vx) {
                continue;
            }
            let src = (vy * v + vx) as usize * 3;
            let offset = (ky * 3 + kx) as usize;
            for &c in &codes[src..src + 3] {
                if c != NO_CODE {
                    f(usize::from(c) * 9 + offset);
                }
            }
        }
    }
}

fn kernel_width(l1: &Layout, l2: &Layout, kernel: usize) -> Result<usize> {
    let (k, patch) = l1.shape().dims2()?;
    let k2 = l2.shape().dims1()?;
    let want = patch_len(kernel);
    if patch != want || k2 != k {
        return Err(candle_core::Error::Msg(format!(
            "conv codes: shapes {:?} and {:?} do not fit (K, {want}) and (K)",
            l1.shape(),
            l2.shape()
        )));
    }
    Ok(k)
}

impl CustomOp2 for ConvCodes {
    fn name(&self) -> &'static str {
        "conv-codes"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let k = kernel_width(l1, l2, self.kernel)?;
        let patch = patch_len(self.kernel);
        let (w, b) = (slice(s1, l1, "conv: weight")?, slice(s2, l2, "conv: bias")?);
        // Transposed so that each patch column's K weights are adjacent.
        let mut wt = vec![0f32; patch * k];
        for (ki, row) in w.chunks_exact(patch).enumerate() {
            for (col, x) in row.iter().enumerate() {
                wt[col * k + ki] = *x;
            }
        }
        let frames = self.codes.frames();
        let codes = self.codes.as_slice();
        let mut out = vec![0f32; frames * N_CELLS * k];
        if k == FAST_K {
            forward_fast(codes, self.kernel, &wt, b, &mut out);
            return Ok((CpuStorage::F32(out), Shape::from((frames, N_CELLS, k))));
        }
        for f in 0..frames {
            let fc = &codes[f * N_CELLS * 3..(f + 1) * N_CELLS * 3];
            for cell in 0..N_CELLS {
                let acc = &mut out[(f * N_CELLS + cell) * k..(f * N_CELLS + cell + 1) * k];
                acc.copy_from_slice(b);
                for_each_column(fc, self.kernel, cell, |col| {
                    for (a, x) in acc.iter_mut().zip(&wt[col * k..(col + 1) * k]) {
                        *a += x;
                    }
                });
                for a in acc.iter_mut() {
                    *a = a.max(0.0);
                }
            }
        }
        Ok((CpuStorage::F32(out), Shape::from((frames, N_CELLS, k))))
    }

    fn bwd(
        &self,
        w: &Tensor,
        _b: &Tensor,
        res: &Tensor,
        grad: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>)> {
        let k = w.dim(0)?;
        let patch = patch_len(self.kernel);
        let both = res.contiguous()?.apply_op2_no_bwd(
            &grad.contiguous()?,
            &ConvCodesBackward {
                codes: self.codes.clone(),
                kernel: self.kernel,
            },
        )?;
        Ok((
            Some(both.narrow(0, 0, k * patch)?.reshape((k, patch))?),
            Some(both.narrow(0, k * patch, k)?),
        ))
    }
}

impl CustomOp2 for ConvCodesBackward {
    fn name(&self) -> &'static str {
        "conv-codes-backward"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let frames = self.codes.frames();
        let (b, n, k) = l1.shape().dims3()?;
        if b != frames || n != N_CELLS || l2.shape() != l1.shape() {
            return Err(candle_core::Error::Msg(format!(
                "conv codes: output {:?} and gradient {:?} do not fit ({frames}, 49, K)",
                l1.shape(),
                l2.shape()
            )));
        }
        let (o, d) = (
            slice(s1, l1, "conv: output")?,
            slice(s2, l2, "conv: gradient")?,
        );
        let codes = self.codes.as_slice();
        let patch = patch_len(self.kernel);
        let mut dwt = vec![0f32; patch * k];
        let mut db = vec![0f32; k];
        if k == FAST_K {
            backward_fast(codes, self.kernel, o, d, &mut dwt, &mut db);
        } else {
            let mut dpre = vec![0f32; k];
            for f in 0..frames {
                let fc = &codes[f * N_CELLS * 3..(f + 1) * N_CELLS * 3];
                for cell in 0..N_CELLS {
                    let at = (f * N_CELLS + cell) * k;
                    // ReLU: no gradient where the output was clamped to 0.
                    for ((p, g), y) in dpre.iter_mut().zip(&d[at..at + k]).zip(&o[at..at + k]) {
                        *p = if *y > 0.0 { *g } else { 0.0 };
                    }
                    for (a, p) in db.iter_mut().zip(&dpre) {
                        *a += p;
                    }
                    for_each_column(fc, self.kernel, cell, |col| {
                        for (a, p) in dwt[col * k..(col + 1) * k].iter_mut().zip(&dpre) {
                            *a += p;
                        }
                    });
                }
            }
        }
        let mut out = vec![0f32; k * patch + k];
        for col in 0..patch {
            for ki in 0..k {
                out[ki * patch + col] = dwt[col * k + ki];
            }
        }
        out[k * patch..].copy_from_slice(&db);
        Ok((CpuStorage::F32(out), Shape::from(k * patch + k)))
    }
}

/// The channel count the paper's network has (`conv_channels` 16, one AVX-512 register):
/// its loops run on fixed-size arrays, with no remainder handling per column. The sums are
/// the same as the general loops' (each channel adds the same terms in the same order).
const FAST_K: usize = 16;

crate::multiversion! {
    /// The forward loop for [`FAST_K`] channels; `wt` is the transposed weight (patch, K).
    fn forward_fast(codes: &[u8], kernel: usize, wt: &[f32], b: &[f32], out: &mut [f32]) {
        const K: usize = FAST_K;
        let Some(&bias) = b.first_chunk::<K>() else {
            return;
        };
        for (fc, frame) in codes
            .chunks_exact(N_CELLS * 3)
            .zip(out.chunks_exact_mut(N_CELLS * K))
        {
            for (cell, dst) in frame.chunks_exact_mut(K).enumerate() {
                let mut acc = bias;
                for_each_column(fc, kernel, cell, |col| {
                    let w = &wt[col * K..col * K + K];
                    for (a, x) in acc.iter_mut().zip(w) {
                        *a += x;
                    }
                });
                for (o, a) in dst.iter_mut().zip(acc) {
                    *o = a.max(0.0);
                }
            }
        }
    }
}

crate::multiversion! {
    /// The backward loop for [`FAST_K`] channels: `dwt` (patch, K) and `db` (K) accumulated
    /// from the output `o` and its gradient `d`.
    fn backward_fast(
        codes: &[u8],
        kernel: usize,
        o: &[f32],
        d: &[f32],
        dwt: &mut [f32],
        db: &mut [f32],
    ) {
        const K: usize = FAST_K;
        let Some(db) = db.first_chunk_mut::<K>() else {
            return;
        };
        for ((fc, of), df) in codes
            .chunks_exact(N_CELLS * 3)
            .zip(o.chunks_exact(N_CELLS * K))
            .zip(d.chunks_exact(N_CELLS * K))
        {
            for (cell, (y, g)) in of.chunks_exact(K).zip(df.chunks_exact(K)).enumerate() {
                // ReLU: no gradient where the output was clamped to 0.
                let mut dpre = [0f32; K];
                for ((p, g), y) in dpre.iter_mut().zip(g).zip(y) {
                    *p = if *y > 0.0 { *g } else { 0.0 };
                }
                for (a, p) in db.iter_mut().zip(&dpre) {
                    *a += p;
                }
                for_each_column(fc, kernel, cell, |col| {
                    for (a, p) in dwt[col * K..col * K + K].iter_mut().zip(&dpre) {
                        *a += p;
                    }
                });
            }
        }
    }
}

/// `ReLU(Conv(O) + b)` of a `kernel`×`kernel` convolution (1 or 3, padding `kernel / 2`) for
/// the frames of `codes`, from the weight (K, `patch_len(kernel)`) and bias (K): (B, 49, K),
/// with its backward to the weight and bias.
pub fn conv_codes(
    codes: &CellCodes,
    kernel: usize,
    weight: &Tensor,
    bias: &Tensor,
) -> Result<Tensor> {
    if kernel != 1 && kernel != 3 {
        return Err(candle_core::Error::Msg(format!(
            "conv codes: kernel {kernel} is not 1 or 3"
        )));
    }
    weight.contiguous()?.apply_op2(
        &bias.contiguous()?,
        ConvCodes {
            codes: codes.clone(),
            kernel,
        },
    )
}
