//! Maps between the agent-up layout of groundscope's view and a graph's layout.

use super::contract::MapLayout;
use crate::env::view::VIEW_SIZE;
use crate::policy::trace::ViewMap;

const N_CELLS: usize = VIEW_SIZE * VIEW_SIZE;

/// 49 agent-up values (`j = vy·7 + vx`) → the graph's layout, into `out`.
pub(super) fn graph_map(v: &[f32], layout: MapLayout, out: &mut [f32]) {
    for (j, x) in v.iter().enumerate().take(N_CELLS) {
        let (vy, vx) = (j / VIEW_SIZE, j % VIEW_SIZE);
        match layout {
            MapLayout::Image => out[vx * VIEW_SIZE + vy] = *x,
            MapLayout::AgentUp => out[j] = *x,
        }
    }
}

/// 49 values in the graph's layout → an agent-up map (`map[vy][vx]`).
pub(super) fn view_map(v: &[f32], layout: MapLayout) -> ViewMap {
    let mut map = [[0.0; VIEW_SIZE]; VIEW_SIZE];
    for (j, x) in v.iter().enumerate().take(N_CELLS) {
        let (a, b) = (j / VIEW_SIZE, j % VIEW_SIZE);
        match layout {
            MapLayout::Image => map[b][a] = *x,
            MapLayout::AgentUp => map[a][b] = *x,
        }
    }
    map
}
