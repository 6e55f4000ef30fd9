//! Generalised advantage estimation (GAE(λ), Schulman et al. 2016) over one environment's
//! frames of a rollout, as torch-ac computes it (and the PyTorch reference's `train_ppo.py`):
//!
//! `δ_t = r_t + γ · m_{t+1} · V_{t+1} − V_t`, `A_t = δ_t + γλ · m_{t+1} · A_{t+1}`,
//! returns `R_t = V_t + A_t`,
//!
//! where `m_t` is 0 when frame `t` starts a new episode (nothing flows back across it) and 1
//! otherwise, and frame `T` is the one after the rollout ([`After`], the bootstrap).

/// The frame after a rollout: its value estimate and its mask.
#[derive(Clone, Copy, Debug)]
pub struct After {
    /// `V_T`, from the memory the next step would use.
    pub value: f32,
    /// `m_T`: 0 when the rollout's last frame ended its episode.
    pub mask: f32,
}

/// Writes `advantages` and `returns` for frames `0..T` of one environment from its `rewards`,
/// `values` and `masks` (all of length T) and the frame after them; `(γ, λ)` = `discount`.
pub fn gae(
    rewards: &[f32],
    values: &[f32],
    masks: &[f32],
    after: After,
    (gamma, lambda): (f32, f32),
    advantages: &mut [f32],
    returns: &mut [f32],
) {
    let t_n = rewards.len();
    let mut next_adv = 0.0;
    for t in (0..t_n).rev() {
        let (next_mask, next_value) = if t + 1 < t_n {
            (masks[t + 1], values[t + 1])
        } else {
            (after.mask, after.value)
        };
        // The same operations in the same order as before this function existed, so runs
        // train to the same bits.
        let delta = rewards[t] + gamma * next_value * next_mask - values[t];
        next_adv = delta + gamma * lambda * next_adv * next_mask;
        advantages[t] = next_adv;
        returns[t] = values[t] + next_adv;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(
        rewards: &[f32],
        values: &[f32],
        masks: &[f32],
        after: After,
        discount: (f32, f32),
    ) -> (Vec<f32>, Vec<f32>) {
        let mut a = vec![0.0; rewards.len()];
        let mut r = vec![0.0; rewards.len()];
        gae(rewards, values, masks, after, discount, &mut a, &mut r);
        (a, r)
    }

    fn close(a: &[f32], b: &[f64]) {
        for (x, y) in a.iter().zip(b) {
            assert!((f64::from(*x) - y).abs() < 1e-6, "{a:?} against {b:?}");
        }
    }

    #[test]
    fn a_hand_computed_episode_and_a_boundary() {
        // γ = 0.9, λ = 0.5; the episode ends at the last frame (the next frame's mask is 0).
        // δ2 = 1 − 0.6 = 0.4; δ1 = 0.9·0.6 − 0.4 = 0.14; δ0 = 0.9·0.4 − 0.2 = 0.16;
        // A2 = 0.4, A1 = 0.14 + 0.45·0.4 = 0.32, A0 = 0.16 + 0.45·0.32 = 0.304.
        let after = After {
            value: 0.7,
            mask: 0.0,
        };
        let (a, r) = run(
            &[0.0, 0.0, 1.0],
            &[0.2, 0.4, 0.6],
            &[1.0, 1.0, 1.0],
            after,
            (0.9, 0.5),
        );
        close(&a, &[0.304, 0.32, 0.4]);
        close(&r, &[0.504, 0.72, 1.0]);
        // Frame 1 starts a new episode: frame 0 sees neither its value nor its advantage
        // (δ0 = −0.2), and the bootstrap flows into the last frame when its episode goes on
        // (δ2 = 1 + 0.9·0.7 − 0.6 = 1.03).
        let after = After {
            value: 0.7,
            mask: 1.0,
        };
        let (a, _) = run(
            &[0.0, 0.0, 1.0],
            &[0.2, 0.4, 0.6],
            &[1.0, 0.0, 1.0],
            after,
            (0.9, 0.5),
        );
        close(&a, &[-0.2, 0.14 + 0.45 * 1.03, 1.03]);
    }

    #[test]
    fn equals_the_discounted_sum_of_residuals() {
        // The closed form behind the torch reference's recursion:
        // A_t = Σ_k (γλ)^k (Π_{j=1..k} m_{t+j}) δ_t+k, in f64, on random frames with episode
        // starts among them.
        let t_n = 40;
        let mut s = 12_345u64;
        let mut next = || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        let rewards: Vec<f32> = (0..t_n).map(|_| next()).collect();
        let values: Vec<f32> = (0..t_n).map(|_| next() * 2.0 - 0.5).collect();
        let masks: Vec<f32> = (0..t_n)
            .map(|_| if next() < 0.15 { 0.0 } else { 1.0 })
            .collect();
        let after = After {
            value: 0.3,
            mask: 1.0,
        };
        let (gamma, lambda) = (0.99f64, 0.95f64);
        let (a, r) = run(&rewards, &values, &masks, after, (0.99, 0.95));
        let m = |t: usize| f64::from(if t < t_n { masks[t] } else { after.mask });
        let v = |t: usize| f64::from(if t < t_n { values[t] } else { after.value });
        let delta = |t: usize| f64::from(rewards[t]) + gamma * m(t + 1) * v(t + 1) - v(t);
        let want: Vec<f64> = (0..t_n)
            .map(|t| {
                let (mut sum, mut weight) = (0.0, 1.0);
                for k in t..t_n {
                    sum += weight * delta(k);
                    weight *= gamma * lambda * m(k + 1);
                }
                sum
            })
            .collect();
        for t in 0..t_n {
            assert!((f64::from(a[t]) - want[t]).abs() < 1e-4, "frame {t}");
            assert!(
                (f64::from(r[t]) - (v(t) + want[t])).abs() < 1e-4,
                "frame {t}"
            );
        }
    }
}
