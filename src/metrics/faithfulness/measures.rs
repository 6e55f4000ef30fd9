//! The formulas of the faithfulness report, on plain vectors: each lives only here.
//!
//! Maps and effects are 49-vectors in agent-up order (`j = vy·7 + vx`, as the policy's maps).

/// A 7×7 map as 49 values in agent-up order.
pub fn flat(map: &crate::policy::ViewMap) -> Vec<f64> {
    map.iter().flatten().map(|x| f64::from(*x)).collect()
}

/// `Δ = ½ Σ_a |p(a) − q(a)|`: the total-variation distance of two action distributions.
pub fn total_variation(p: &[f32], q: &[f32]) -> f64 {
    0.5 * p
        .iter()
        .zip(q)
        .map(|(a, b)| f64::from((a - b).abs()))
        .sum::<f64>()
}

/// Ranks of `xs` from 1, ties given their average rank (Spearman's convention).
pub fn average_ranks(xs: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..xs.len()).collect();
    order.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
    let mut ranks = vec![0.0; xs.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && xs[order[j + 1]] == xs[order[i]] {
            j += 1;
        }
        // Positions i..=j (0-based) share the mean of ranks i+1..=j+1.
        let r = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            ranks[k] = r;
        }
        i = j + 1;
    }
    ranks
}

/// Spearman's rank correlation of `x` and `y` (Pearson's on average ranks); `None` when
/// either is constant (no ranking to compare) or the lengths differ.
pub fn rank_correlation(x: &[f64], y: &[f64]) -> Option<f64> {
    if x.len() != y.len() || x.len() < 2 {
        return None;
    }
    let (rx, ry) = (average_ranks(x), average_ranks(y));
    let n = rx.len() as f64;
    let (mx, my) = (rx.iter().sum::<f64>() / n, ry.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in rx.iter().zip(&ry) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx).powi(2);
        syy += (b - my).powi(2);
    }
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

/// Index of the largest value (the first of equal ones).
pub fn argmax(xs: &[f64]) -> usize {
    let mut best = 0;
    for (i, x) in xs.iter().enumerate() {
        if *x > xs[best] {
            best = i;
        }
    }
    best
}

/// Area under a curve sampled at `k/n`, `k = 0..=n` (trapezoids), divided by `reference`
/// (the unperturbed probability of the chosen action): a deletion curve that falls early has
/// a small area, an insertion curve that rises early a large one, and a curve that stays at
/// the reference has area 1. `None` for fewer than two points or a reference of 0.
pub fn normalised_auc(curve: &[f64], reference: f64) -> Option<f64> {
    if curve.len() < 2 || reference <= 0.0 {
        return None;
    }
    let n = (curve.len() - 1) as f64;
    let area: f64 = curve
        .windows(2)
        .map(|w| f64::midpoint(w[0], w[1]) / n)
        .sum();
    Some(area / reference)
}

/// A curve sampled at `k/n` read at `points` evenly spaced fractions from 0 to 1 (linear
/// interpolation), so that curves over different object counts can be averaged.
pub fn resample(curve: &[f64], points: usize) -> Vec<f64> {
    if curve.is_empty() || points == 0 {
        return Vec::new();
    }
    let n = (curve.len() - 1) as f64;
    (0..points)
        .map(|i| {
            let x = if points == 1 {
                0.0
            } else {
                i as f64 / (points - 1) as f64
            } * n;
            let lo = x.floor() as usize;
            let hi = (lo + 1).min(curve.len() - 1);
            let t = x - lo as f64;
            curve[lo] * (1.0 - t) + curve[hi] * t
        })
        .collect()
}

/// Localisation of a map on a set of related cells, each beside its value for a uniform map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Localisation {
    /// Whether the map's largest cell is a related cell (ties shared,
    /// [`crate::metrics::grounding::pointing_flat`]).
    pub pointing_game: f64,
    /// `Σ map` over the related cells.
    pub relevance_mass: f64,
    /// Of the map's `n` largest cells (`n` = related cells), the fraction that are related.
    pub rank_accuracy: f64,
    /// The value of all three for a uniform map (a random cell): `n / 49`.
    pub chance: f64,
}

/// [`Localisation`] of `map` (49 values) on `related` cell indices; `None` when nothing is
/// related.
pub fn localisation(map: &[f64], related: &[usize]) -> Option<Localisation> {
    if related.is_empty() || map.is_empty() {
        return None;
    }
    let is_related = |j: usize| related.contains(&j);
    let mut order: Vec<usize> = (0..map.len()).collect();
    // Largest first; equal values keep index order, as `argmax`.
    order.sort_by(|&a, &b| map[b].total_cmp(&map[a]).then(a.cmp(&b)));
    let top = &order[..related.len().min(order.len())];
    Some(Localisation {
        pointing_game: crate::metrics::grounding::pointing_flat(map, related),
        relevance_mass: crate::metrics::grounding::relevance_mass_flat(map, related),
        rank_accuracy: top.iter().filter(|&&j| is_related(j)).count() as f64 / top.len() as f64,
        chance: related.len() as f64 / map.len() as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn total_variation_is_half_the_l1_distance() {
        assert_eq!(total_variation(&[1.0, 0.0], &[0.0, 1.0]), 1.0);
        assert_eq!(total_variation(&[0.5, 0.5], &[0.5, 0.5]), 0.0);
        assert!((total_variation(&[0.7, 0.3], &[0.5, 0.5]) - 0.2).abs() < 1e-6);
    }

    #[test]
    fn ties_share_their_average_rank() {
        assert_eq!(
            average_ranks(&[10.0, 20.0, 20.0, 5.0]),
            [2.0, 3.5, 3.5, 1.0]
        );
    }

    #[test]
    fn rank_correlation_on_hand_made_vectors() {
        let x = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert!((rank_correlation(&x, &[2.0, 4.0, 6.0, 8.0, 100.0]).unwrap() - 1.0).abs() < 1e-12);
        assert!((rank_correlation(&x, &[5.0, 4.0, 3.0, 2.0, 1.0]).unwrap() + 1.0).abs() < 1e-12);
        // scipy.stats.spearmanr([1,2,3,4,5], [5,6,7,8,7]) = 0.8207826816681233
        let r = rank_correlation(&x, &[5.0, 6.0, 7.0, 8.0, 7.0]).unwrap();
        assert!((r - 0.820_782_681_668_123_3).abs() < 1e-12, "{r}");
        assert_eq!(rank_correlation(&x, &[1.0; 5]), None);
        assert_eq!(rank_correlation(&x, &[1.0; 4]), None);
    }

    #[test]
    fn aucs_on_hand_made_curves() {
        // Flat: 1. Falls to 0 at once: half a step of area over 2 steps = 0.25.
        assert_eq!(normalised_auc(&[0.8, 0.8, 0.8], 0.8), Some(1.0));
        assert_eq!(normalised_auc(&[0.8, 0.0, 0.0], 0.8), Some(0.25));
        assert_eq!(normalised_auc(&[0.5, 0.25], 0.5), Some(0.75));
        // Insertion from an empty view that reaches the reference only at the end.
        assert_eq!(normalised_auc(&[0.0, 0.0, 0.5], 0.5), Some(0.25));
        assert_eq!(normalised_auc(&[0.5, 1.0], 0.0), None);
        assert_eq!(normalised_auc(&[1.0], 1.0), None);
    }

    #[test]
    fn resampling_interpolates_between_removals() {
        assert_eq!(resample(&[1.0, 0.0], 3), [1.0, 0.5, 0.0]);
        assert_eq!(resample(&[1.0, 0.5, 0.0], 5), [1.0, 0.75, 0.5, 0.25, 0.0]);
    }

    #[test]
    fn localisation_against_uniform_chance() {
        let mut map = vec![0.0; 49];
        map[10] = 0.6;
        map[11] = 0.3;
        map[12] = 0.1;
        let l = localisation(&map, &[11, 12]).unwrap();
        assert_eq!(l.pointing_game, 0.0);
        assert!((l.relevance_mass - 0.4).abs() < 1e-12);
        assert_eq!(l.rank_accuracy, 0.5);
        assert!((l.chance - 2.0 / 49.0).abs() < 1e-12);
        let uniform = vec![1.0 / 49.0; 49];
        let u = localisation(&uniform, &[11, 12]).unwrap();
        // A uniform map's mass on the related cells is exactly the chance level.
        assert!((u.relevance_mass - u.chance).abs() < 1e-12);
        // ... and so is its pointing game: ties share the point.
        assert!((u.pointing_game - u.chance).abs() < 1e-12);
        assert_eq!(localisation(&map, &[]), None);
    }
}
