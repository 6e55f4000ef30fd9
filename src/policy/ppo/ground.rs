//! The auxiliary grounding loss of `train --ground-loss λ`: the word maps and `M` supervised by
//! what the world says each word names in view ([`crate::env::targets`]). The one place its
//! formula lives.
//!
//! For a frame and a scored word i whose objects are in view (cells `T_i`), the term is
//! `−ln Σ_{j∈T_i} A_ij`, the log of the map's relevance mass on them; for `M`, on the objects
//! the clauses waited on matched (`T_M`), `−ln Σ_{j∈T_M} M_j`. Each is averaged over the pairs
//! that have targets (frames with none in view add nothing), and the loss is
//! `λ · (mean over words + mean over M)`. Maximising the mass rather than a cross-entropy
//! against a one-hot lets a map spread over several named objects (two red balls) but not
//! beyond them.

use candle_core::{D, Device, Tensor};

use crate::env::targets::{pending_targets, word_targets};
use crate::env::view::{Observation, VIEW_SIZE, ViewCell};
use crate::env::world::World;
use crate::policy::error::PolicyError;
use crate::policy::obs::N_CELLS;

/// Smallest mass fed to `ln`: keeps a map with nothing on its targets finite.
const TINY_MASS: f64 = 1e-6;

/// The cells one frame's maps are supervised on, as bit sets over the 49 view cells
/// (bit `vy·7 + vx`, the networks' cell order).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(super) struct FrameTargets {
    /// `(word index, cells)` for every scored word with an object in view.
    pub(super) words: Vec<(usize, u64)>,
    /// `M`'s target cells (0: none in view).
    pub(super) combined: u64,
}

/// The bit set of `cells`.
fn bits(cells: &[ViewCell]) -> u64 {
    cells
        .iter()
        .fold(0, |acc, &(vx, vy)| acc | 1 << (vy * VIEW_SIZE + vx))
}

impl FrameTargets {
    /// What `world` (as the agent saw it, `obs`) says the `n_words` words of its mission name.
    pub(super) fn of(world: &World, obs: &Observation, n_words: usize) -> Self {
        let words = word_targets(world, obs, n_words)
            .into_iter()
            .filter(|t| !t.cells.is_empty())
            .map(|t| (t.word, bits(&t.cells)))
            .collect();
        Self {
            words,
            combined: bits(&pending_targets(world, obs)),
        }
    }
}

/// The loss for frames `targets` (one per row of `a` (B, m, 49) and `m` (B, 49)), times
/// `lambda`; `None` when no row has a target in view. Also returns the unweighted term, for
/// the log.
pub(super) fn ground_loss(
    a: &Tensor,
    m: &Tensor,
    targets: &[&FrameTargets],
    lambda: f64,
) -> Result<Option<(Tensor, f64)>, PolicyError> {
    let (b, words, cells) = a.dims3()?;
    debug_assert_eq!(cells, N_CELLS);
    let mut word_mask = vec![0f32; b * words * cells];
    let mut word_on = vec![0f32; b * words];
    let mut m_mask = vec![0f32; b * cells];
    let mut m_on = vec![0f32; b];
    for (r, t) in targets.iter().enumerate() {
        for &(w, set) in &t.words {
            if w >= words {
                continue;
            }
            word_on[r * words + w] = 1.0;
            fill(&mut word_mask[(r * words + w) * cells..][..cells], set);
        }
        if t.combined != 0 {
            m_on[r] = 1.0;
            fill(&mut m_mask[r * cells..][..cells], t.combined);
        }
    }
    let (n_words, n_m) = (word_on.iter().sum::<f32>(), m_on.iter().sum::<f32>());
    if n_words == 0.0 && n_m == 0.0 {
        return Ok(None);
    }
    let dev = Device::Cpu;
    let term = |maps: &Tensor, mask: Vec<f32>, on: Vec<f32>, shape: &[usize], n: f32| {
        if n == 0.0 {
            return Ok::<_, PolicyError>(None);
        }
        let mask = Tensor::from_vec(mask, maps.shape(), &dev)?;
        let on = Tensor::from_vec(on, shape, &dev)?;
        let mass = (maps * mask)?.sum(D::Minus1)?.clamp(TINY_MASS, 1.0)?;
        Ok(Some(
            ((mass.log()? * on)?.sum_all()? / f64::from(n))?.neg()?,
        ))
    };
    let total = match (
        term(a, word_mask, word_on, &[b, words], n_words)?,
        term(m, m_mask, m_on, &[b], n_m)?,
    ) {
        (Some(w), Some(c)) => (w + c)?,
        (Some(t), None) | (None, Some(t)) => t,
        (None, None) => return Ok(None),
    };
    let plain = f64::from(total.to_scalar::<f32>()?);
    Ok(Some(((total * lambda)?, plain)))
}

/// Sets to 1 the entries of `row` (49 cells) whose bit is in `set`.
fn fill(row: &mut [f32], set: u64) {
    for (j, x) in row.iter_mut().enumerate() {
        if set >> j & 1 == 1 {
            *x = 1.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn maps(rows: &[[f32; N_CELLS]]) -> Tensor {
        let v: Vec<f32> = rows.iter().flatten().copied().collect();
        Tensor::from_vec(v, (rows.len(), N_CELLS), &Device::Cpu).unwrap()
    }

    #[test]
    fn the_loss_is_minus_the_log_mass_on_the_targets_averaged_over_pairs() {
        // Two frames, one word each: frame 0's map puts 0.5 on its target, frame 1's 0.25 on
        // its two targets together; M puts 0.8 on frame 0's target, frame 1 has none.
        let mut a0 = [0.5 / 48.0; N_CELLS];
        a0[10] = 0.5;
        let mut a1 = [0.75 / 47.0; N_CELLS];
        a1[3] = 0.125;
        a1[4] = 0.125;
        let a = maps(&[a0, a1]).reshape((2, 1, N_CELLS)).unwrap();
        let mut m0 = [0.2 / 48.0; N_CELLS];
        m0[10] = 0.8;
        let m = maps(&[m0, [1.0 / 49.0; N_CELLS]]);
        let t0 = FrameTargets {
            words: vec![(0, 1 << 10)],
            combined: 1 << 10,
        };
        let t1 = FrameTargets {
            words: vec![(0, 1 << 3 | 1 << 4)],
            combined: 0,
        };
        let (loss, plain) = ground_loss(&a, &m, &[&t0, &t1], 2.0).unwrap().unwrap();
        let want = -(0.5f64.ln() + 0.25f64.ln()) / 2.0 - 0.8f64.ln();
        assert!((plain - want).abs() < 1e-5, "{plain} vs {want}");
        let l = f64::from(loss.to_scalar::<f32>().unwrap());
        assert!((l - 2.0 * want).abs() < 1e-4, "{l}");
        // No target anywhere: no term.
        let none = FrameTargets::default();
        assert!(ground_loss(&a, &m, &[&none, &none], 1.0).unwrap().is_none());
    }

    #[test]
    fn the_gradient_moves_mass_onto_the_targets() {
        let logits = candle_core::Var::from_tensor(
            &Tensor::zeros((1, 1, N_CELLS), candle_core::DType::F32, &Device::Cpu).unwrap(),
        )
        .unwrap();
        let a = candle_nn::ops::softmax(logits.as_tensor(), D::Minus1).unwrap();
        let m = a.squeeze(1).unwrap();
        let t = FrameTargets {
            words: vec![(0, 1 << 7)],
            combined: 1 << 7,
        };
        let (loss, _) = ground_loss(&a, &m, &[&t], 1.0).unwrap().unwrap();
        let g = loss.backward().unwrap();
        let g = g.get(logits.as_tensor()).unwrap().flatten_all().unwrap();
        let g = g.to_vec1::<f32>().unwrap();
        // Descending the gradient raises the target's logit and lowers every other.
        assert!(g[7] < 0.0);
        assert!(g.iter().enumerate().all(|(j, &x)| j == 7 || x > 0.0));
    }
}
