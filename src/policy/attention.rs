//! The text-visual attention of the paper (§3.3, eqs. 3–7); each formula lives only here.
//!
//! Shapes, for a batch of B frames, m words (padded) and 49 view cells:
//! - `q`: (B, m, d_k) word queries `Q = g̃ W_q`; `kc`: (B, 49, d_k) cell keys `Kc = Õ W_k`;
//! - `a`: (B, m, 49), `A = softmax_rows(Q Kcᵀ / √d_k)`, row i is word i's map;
//! - `h`: (B, m), `H_i = −Σ_j A_ij ln A_ij` in nats, with `0 · ln 0 = 0`;
//! - `w`: (B, m), `w = softmax(−H / T)` over the real words only (padding gets weight 0),
//!   with the word temperature `T` of the model configuration: 1 as the paper writes it (the
//!   default), larger to weigh the words more evenly;
//! - `m`: (B, 49), `M = Σ_i w_i A_i`;
//! - `f`: (B, 49, K), `F_j = s · M_j · Õ_j`, with the filter scale `s` of the model
//!   configuration: 49 by default, 1 as the paper writes it.
//!
//! The default factor 49 is our choice (issue #4): with a uniform `M` it passes `Õ` through
//! unchanged, so the LSTM input keeps the baseline's scale instead of shrinking 49-fold (it
//! trained markedly faster). It also means a network whose maps go flat loses nothing — it
//! becomes the baseline — while with the paper's factor 1 a flat `M` shrinks every input and
//! a map on the target passes that cell whole. A constant factor changes no attention value.

use candle_core::{D, Tensor};

use super::error::PolicyError;

/// Smallest probability fed to `ln`, so that `0 · ln 0` evaluates to `0 · ln(tiny) = 0`.
const TINY: f64 = 1e-30;

/// Eq. 3: the scaled scores `Q Kcᵀ / √d_k`, (B, m, 49).
pub fn scores(q: &Tensor, kc: &Tensor) -> Result<Tensor, PolicyError> {
    let d_k = q.dim(D::Minus1)? as f64;
    Ok((q.matmul(&kc.transpose(1, 2)?)? / d_k.sqrt())?)
}

/// Eq. 3 regrouped for the fused training path: since `Kc = Õ W_kᵀ`,
/// `Q Kcᵀ / √d_k = (Q W_k / √d_k) Õᵀ`; this returns `Q W_k / √d_k`, (…, m, K), for `q`
/// (…, m, d_k) and `W_k` (d_k, K). Computed once per distinct mission, it spares the keys of
/// every cell of every frame.
pub fn keyed_queries(q: &Tensor, wk: &Tensor) -> Result<Tensor, PolicyError> {
    let d_k = q.dim(D::Minus1)?;
    let (rows, k) = (q.elem_count() / d_k, wk.dim(1)?);
    let mut dims = q.dims().to_vec();
    *dims.last_mut().unwrap_or(&mut 0) = k;
    Ok((q.reshape((rows, d_k))?.matmul(wk)? / (d_k as f64).sqrt())?.reshape(dims)?)
}

/// Eq. 3–4: `A = softmax_rows(Q Kcᵀ / √d_k)`, (B, m, 49).
pub fn attention_maps(q: &Tensor, kc: &Tensor) -> Result<Tensor, PolicyError> {
    maps_from_scores(&scores(q, kc)?, None)
}

/// Eq. 4 from the scores `s` (…, m, 49): each row's softmax over the cells, or with the null
/// logits `s0` (…, m, 1) a softmax over the cells and the null key whose share is spread
/// evenly over the cells ([`attention_maps_null`]).
pub fn maps_from_scores(s: &Tensor, s0: Option<&Tensor>) -> Result<Tensor, PolicyError> {
    let Some(s0) = s0 else {
        return Ok(candle_nn::ops::softmax(s, D::Minus1)?);
    };
    let p = candle_nn::ops::softmax(&Tensor::cat(&[s, s0], D::Minus1)?, D::Minus1)?;
    let n = s.dim(D::Minus1)?;
    let spread = (p.narrow(D::Minus1, n, 1)? / n as f64)?;
    Ok(p.narrow(D::Minus1, 0, n)?.broadcast_add(&spread)?)
}

/// Eq. 4 with the null key `k₀` (1, d_k) of [`crate::policy::ModelConfig::null_key`]: each
/// word's softmax runs over the 49 cells and `k₀`, `[p_i1 … p_i49, p_i0] = softmax([Q_i Kcᵀ,
/// Q_i k₀ᵀ] / √d_k)`, and the null key's share is spread evenly over the cells:
/// `A_ij = p_ij + p_i0 / 49`, (B, m, 49), each row still summing to 1. A word that finds
/// nothing it names can so make its map flat, and a flat `M` passes the whole view.
pub fn attention_maps_null(q: &Tensor, kc: &Tensor, k0: &Tensor) -> Result<Tensor, PolicyError> {
    maps_from_scores(&scores(q, kc)?, Some(&null_logits(q, k0)?))
}

/// The null key's logits `Q k₀ᵀ / √d_k`, (…, m, 1), for `q` (…, m, d_k) and `k₀` (1, d_k):
/// the column the fused training path appends to the keyed queries.
pub fn null_logits(q: &Tensor, k0: &Tensor) -> Result<Tensor, PolicyError> {
    let d_k = q.dim(D::Minus1)? as f64;
    Ok((q.broadcast_matmul(&k0.t()?)? / d_k.sqrt())?)
}

/// Eq. 5: `H_i = −Σ_j A_ij ln A_ij` (nats), (B, m).
pub fn entropies(a: &Tensor) -> Result<Tensor, PolicyError> {
    let ln_a = a.clamp(TINY, 1.0)?.log()?;
    Ok((a * ln_a)?.sum(D::Minus1)?.neg()?)
}

/// Eq. 5: `w = softmax(−H / T)` over real words; `mask` (B, m) is 1 for real words, 0 for
/// padding; `t` is the word temperature (1 in the paper).
pub fn word_weights(h: &Tensor, mask: &Tensor, t: f32) -> Result<Tensor, PolicyError> {
    // Padding gets −1e9 before the softmax, i.e. exactly 0 after it. T = 1 skips the division,
    // so the paper's weights are computed exactly as before the option existed.
    let neg_h = if t == 1.0 {
        h.neg()?
    } else {
        (h.neg()? / f64::from(t))?
    };
    let masked = ((&neg_h * mask)? + ((mask - 1.0)? * 1e9)?)?;
    Ok(candle_nn::ops::softmax(&masked, D::Minus1)?)
}

/// Eq. 7: `M = Σ_i w_i A_i`, (B, 49).
pub fn combined_map(w: &Tensor, a: &Tensor) -> Result<Tensor, PolicyError> {
    Ok(w.unsqueeze(1)?.matmul(a)?.squeeze(1)?)
}

/// `F_j = scale · M_j · Õ_j`: every cell's feature vector scaled by its combined attention,
/// (B, 49, K); `scale` is the model's `filter_scale` (49 by default, 1 as in the paper).
pub fn filter_features(o: &Tensor, m: &Tensor, scale: u32) -> Result<Tensor, PolicyError> {
    Ok(o.broadcast_mul(&(m * f64::from(scale))?.unsqueeze(2)?)?)
}

/// Everything the attention module computes for a batch.
#[derive(Clone, Debug)]
pub struct AttentionOut {
    /// (B, m, 49) per-word maps.
    pub a: Tensor,
    /// (B, m) entropies.
    pub h: Tensor,
    /// (B, m) word weights.
    pub w: Tensor,
    /// (B, 49) combined map.
    pub m: Tensor,
    /// (B, 49, K) filtered features.
    pub f: Tensor,
}

/// A change made to the attention inside a forward pass, for faithfulness tests: `M` is a
/// causal point of the network (it multiplies the features), so the layers after it see the
/// changed `M` while everything before it (maps, entropies) stays as computed.
#[derive(Clone, Debug)]
pub enum Intervention {
    /// Replace `M` by these maps, (B, 49), each row summing to 1.
    SetM(Tensor),
    /// Multiply the word weights `w` by these factors, (B, m), and renormalise each row to
    /// sum to 1 (a factor 0 removes a word from `M`).
    ScaleWeights(Tensor),
}

/// Eqs. 3–7 and the filter (factor `scale`, word temperature `t`), given queries, keys, the
/// word mask and the cell features `Õ`.
pub fn attend(
    q: &Tensor,
    kc: &Tensor,
    mask: &Tensor,
    o: &Tensor,
    scale: u32,
    t: f32,
) -> Result<AttentionOut, PolicyError> {
    attend_with(q, kc, mask, o, scale, t, None, None)
}

/// [`attend`] with the model's null key `k₀` (maps by [`attention_maps_null`]; `None` for the
/// paper's eq. 4) and an optional [`Intervention`] applied to `w` or `M` before the filter.
#[expect(
    clippy::too_many_arguments,
    reason = "the composite attention's whole input: queries, keys, mask, features, the two model constants, the null key and an intervention"
)]
pub fn attend_with(
    q: &Tensor,
    kc: &Tensor,
    mask: &Tensor,
    o: &Tensor,
    scale: u32,
    t: f32,
    null_key: Option<&Tensor>,
    intervention: Option<&Intervention>,
) -> Result<AttentionOut, PolicyError> {
    let a = match null_key {
        Some(k0) => attention_maps_null(q, kc, k0)?,
        None => attention_maps(q, kc)?,
    };
    let h = entropies(&a)?;
    let mut w = word_weights(&h, mask, t)?;
    if let Some(Intervention::ScaleWeights(factors)) = intervention {
        let scaled = (&w * factors)?;
        let total = scaled.sum_keepdim(D::Minus1)?.clamp(TINY, f64::MAX)?;
        w = scaled.broadcast_div(&total)?;
    }
    let m = match intervention {
        Some(Intervention::SetM(m)) => m.clone(),
        _ => combined_map(&w, &a)?,
    };
    let f = filter_features(o, &m, scale)?;
    Ok(AttentionOut { a, h, w, m, f })
}

#[cfg(test)]
mod tests {
    use candle_core::Device;

    use super::*;

    fn round(v: &[f32], digits: i32) -> Vec<f32> {
        let s = 10f32.powi(digits);
        v.iter().map(|x| (x * s).round() / s).collect()
    }

    #[test]
    fn maps_are_scaled_softmaxes_of_query_key_products() {
        // One frame, one word, d_k = 4, two informative cells.
        let q = Tensor::from_vec(vec![2f32, 0., 0., 0.], (1, 1, 4), &Device::Cpu).unwrap();
        let mut keys = vec![0f32; 49 * 4];
        keys[0] = 1.0; // cell 0: q·k = 2 → score 2/√4 = 1
        keys[4] = 2.0; // cell 1: q·k = 4 → score 2
        let kc = Tensor::from_vec(keys, (1, 49, 4), &Device::Cpu).unwrap();
        let a = attention_maps(&q, &kc)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1::<f32>()
            .unwrap();
        let z = 1f32.exp() + 2f32.exp() + 47.0;
        assert!((a[0] - 1f32.exp() / z).abs() < 1e-6);
        assert!((a[1] - 2f32.exp() / z).abs() < 1e-6);
        assert!((a[2] - 1.0 / z).abs() < 1e-6);
        assert!((a.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn the_null_keys_share_is_spread_evenly_over_the_cells() {
        // One frame, two words, d_k = 2; cell 3 matches both words' queries by 4 (score 4/√2).
        let q = Tensor::from_vec(vec![1f32, 0., 0., 1.], (1, 2, 2), &Device::Cpu).unwrap();
        let mut keys = vec![0f32; 49 * 2];
        keys[3 * 2] = 4.0;
        keys[3 * 2 + 1] = 4.0;
        let kc = Tensor::from_vec(keys, (1, 49, 2), &Device::Cpu).unwrap();
        // k₀ matches word 1 by 10 (score 10/√2) and word 0 not at all (score 0).
        let k0 = Tensor::from_vec(vec![0f32, 10.], (1, 2), &Device::Cpu).unwrap();
        let a = attention_maps_null(&q, &kc, &k0)
            .unwrap()
            .to_vec3::<f32>()
            .unwrap();
        let r = 2f32.sqrt();
        for (i, null_score) in [(0, 0.0), (1, 10.0 / r)] {
            let z = (4.0 / r).exp() + 48.0 + f32::exp(null_score);
            let spread = f32::exp(null_score) / z / 49.0;
            assert!((a[0][i][3] - ((4.0 / r).exp() / z + spread)).abs() < 1e-6);
            assert!((a[0][i][0] - (1.0 / z + spread)).abs() < 1e-6);
            assert!((a[0][i].iter().sum::<f32>() - 1.0).abs() < 1e-5);
        }
        // Word 0's map is peaked on cell 3; word 1's is mostly the null key's even share,
        // nearly flat (entropy close to ln 49) and still highest where its query matches.
        let h = entropies(&Tensor::from_vec(a[0].concat(), (1, 2, 49), &Device::Cpu).unwrap())
            .unwrap()
            .to_vec2::<f32>()
            .unwrap();
        assert!(a[0][0][3] > 0.2 && h[0][0] < h[0][1], "{h:?}");
        assert!(h[0][1] > 0.99 * 49f32.ln(), "{h:?}");
        assert!(a[0][1][3] > a[0][1][0]);
    }

    #[test]
    fn entropy_of_one_hot_is_zero_and_of_uniform_is_ln_n() {
        let mut one_hot = vec![0f32; 49];
        one_hot[10] = 1.0;
        let uniform = vec![1.0 / 49.0; 49];
        let mut half = vec![0f32; 49];
        half[0] = 0.5;
        half[1] = 0.5;
        let a =
            Tensor::from_vec([one_hot, uniform, half].concat(), (1, 3, 49), &Device::Cpu).unwrap();
        let h = entropies(&a)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1::<f32>()
            .unwrap();
        assert_eq!(round(&h, 5), round(&[0.0, 49f32.ln(), 2f32.ln()], 5));
    }

    #[test]
    fn weights_mask_padding_and_split_ties_evenly() {
        // Words 0 and 1 tie (H = 1), word 2 is focused (H = 0), word 3 is padding.
        let h = Tensor::from_vec(vec![1f32, 1., 0., 0.], (1, 4), &Device::Cpu).unwrap();
        let mask = Tensor::from_vec(vec![1f32, 1., 1., 0.], (1, 4), &Device::Cpu).unwrap();
        let weights = |t: f32| {
            word_weights(&h, &mask, t)
                .unwrap()
                .flatten_all()
                .unwrap()
                .to_vec1::<f32>()
                .unwrap()
        };
        let e = (-1f32).exp();
        let z = 2.0 * e + 1.0;
        assert_eq!(
            round(&weights(1.0), 6),
            round(&[e / z, e / z, 1.0 / z, 0.0], 6)
        );
        // At T = 4 the focused word's lead shrinks from e to e^(1/4).
        let e4 = (-0.25f32).exp();
        let z4 = 2.0 * e4 + 1.0;
        assert_eq!(
            round(&weights(4.0), 6),
            round(&[e4 / z4, e4 / z4, 1.0 / z4, 0.0], 6)
        );
    }

    #[test]
    fn combined_map_is_the_weighted_sum_and_sums_to_one() {
        let mut a0 = vec![0f32; 49];
        a0[0] = 1.0;
        let mut a1 = vec![0f32; 49];
        a1[1] = 1.0;
        let a = Tensor::from_vec([a0, a1].concat(), (1, 2, 49), &Device::Cpu).unwrap();
        let w = Tensor::from_vec(vec![0.25f32, 0.75], (1, 2), &Device::Cpu).unwrap();
        let m = combined_map(&w, &a)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1::<f32>()
            .unwrap();
        assert_eq!(&m[..3], &[0.25, 0.75, 0.0]);
        assert!((m.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        // Uniform M leaves Õ unchanged with the default factor, and shrinks it 49-fold with
        // the paper's.
        let o = Tensor::ones((1, 49, 3), candle_core::DType::F32, &Device::Cpu).unwrap();
        let uni = Tensor::full(1f32 / 49.0, (1, 49), &Device::Cpu).unwrap();
        let filtered = |scale: u32| {
            filter_features(&o, &uni, scale)
                .unwrap()
                .flatten_all()
                .unwrap()
                .to_vec1::<f32>()
                .unwrap()
        };
        assert!(filtered(49).iter().all(|x| (x - 1.0).abs() < 1e-5));
        assert!(filtered(1).iter().all(|x| (x - 1.0 / 49.0).abs() < 1e-7));
    }
}
