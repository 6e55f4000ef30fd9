//! Whether `M` and the occlusion map Δ peak on the same cells: Spearman ρ ranks all 48 cells,
//! where a few hot cells matter and the many cold ones mostly add noise, so a low ρ can sit
//! beside maps that look at the same object. These say whether they do.

use crate::env::AGENT_IN_VIEW;
use crate::policy::ViewMap;

/// How many of the highest cells of `M` and Δ are compared.
pub const TOP_K: usize = 3;

/// The `k` view cells with the highest values, highest first (ties in view order), the
/// agent's own cell left out as in ρ.
pub fn top_cells(map: &ViewMap, k: usize) -> Vec<(usize, usize)> {
    let mut cells: Vec<((usize, usize), f32)> = (0..7)
        .flat_map(|vy| (0..7).map(move |vx| (vx, vy)))
        .filter(|&c| c != AGENT_IN_VIEW)
        .map(|(vx, vy)| ((vx, vy), map[vy][vx]))
        .collect();
    cells.sort_by(|a, b| b.1.total_cmp(&a.1));
    cells.into_iter().take(k).map(|(c, _)| c).collect()
}

/// How far the peaks of `M` and Δ agree: cells shared by their top [`TOP_K`], and whether
/// their highest cells are the same. ρ runs over all 48 cells, where a few hot cells matter
/// and the many cold ones mostly add noise; this says whether they look at the same place.
pub fn peak_agreement(m: &ViewMap, delta: &ViewMap) -> (usize, bool) {
    let (a, b) = (top_cells(m, TOP_K), top_cells(delta, TOP_K));
    let shared = a.iter().filter(|c| b.contains(c)).count();
    (shared, !a.is_empty() && a.first() == b.first())
}

/// One line for the peaks: `"top-3 cells shared 2/3 · same peak cell"`.
pub fn peak_line(m: &ViewMap, delta: &ViewMap) -> String {
    let (shared, same) = peak_agreement(m, delta);
    format!(
        "top-{TOP_K} cells shared {shared}/{TOP_K} · {}",
        if same {
            "same peak cell"
        } else {
            "different peak cells"
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_agree_when_the_hot_cells_are_the_same() {
        let mut m = [[0.0; 7]; 7];
        let mut d = [[0.0; 7]; 7];
        m[2][1] = 0.5;
        m[2][2] = 0.3;
        m[4][4] = 0.1;
        d[2][1] = 0.9;
        d[0][0] = 0.2;
        d[2][2] = 0.1;
        // The agent's cell never counts, however high.
        d[6][3] = 5.0;
        assert_eq!(top_cells(&d, 3), [(1, 2), (0, 0), (2, 2)]);
        assert_eq!(peak_agreement(&m, &d), (2, true));
        assert_eq!(peak_line(&m, &d), "top-3 cells shared 2/3 · same peak cell");
        d[2][1] = 0.0;
        assert_eq!(peak_agreement(&m, &d), (1, false));
    }
}
