//! The agent's 7×7 egocentric view.
//!
//! Conventions (MiniGrid's): arrays are x-major, `image[vx][vy]`; `vx` is the view column
//! (0 = the agent's left, 6 = its right), `vy` the view row (0 = farthest ahead, 6 = the agent's
//! row); the agent sits at `(3, 6)` facing up (towards smaller `vy`). The view reaches 6 cells
//! ahead, 3 to each side and none behind.

use super::grid::{DIR_TO_VEC, Grid, Pos};
use super::object::{Cell, WorldObj, encode_cell};

/// Side of the square view (`agent_view_size`).
pub const VIEW_SIZE: usize = 7;

/// The agent's cell in its own view.
pub const AGENT_IN_VIEW: (usize, usize) = (VIEW_SIZE / 2, VIEW_SIZE - 1);

/// A cell of the view, `(vx, vy)`.
pub type ViewCell = (usize, usize);

/// One observation image, `image[vx][vy] = (type, colour, state)`; unseen cells are `(0, 0, 0)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Observation {
    /// x-major 7×7×3 encoding, as minigrid's `obs["image"]`.
    pub image: [[[u8; 3]; VIEW_SIZE]; VIEW_SIZE],
}

impl Observation {
    /// The encoding at `cell_in_view`.
    #[inline]
    pub fn at(&self, (vx, vy): ViewCell) -> [u8; 3] {
        self.image[vx][vy]
    }

    /// Whether the cell was visible (not `(0, 0, 0)`).
    #[inline]
    pub fn visible(&self, cell_in_view: ViewCell) -> bool {
        self.at(cell_in_view)[0] != 0
    }

    /// The image as nested vectors, like numpy's `.tolist()`.
    pub fn to_nested(&self) -> Vec<Vec<Vec<u8>>> {
        self.image
            .iter()
            .map(|col| col.iter().map(|c| c.to_vec()).collect())
            .collect()
    }
}

/// World position of view cell `(vx, vy)` for an agent at `agent_pos` facing `agent_dir`:
/// `agent_pos + d·(6 − vy) + r·(vx − 3)` with `d = DIR_TO_VEC[dir]`, `r = (−d.y, d.x)`.
#[inline]
pub fn world_from_view(agent_pos: Pos, agent_dir: u8, (vx, vy): ViewCell) -> Pos {
    let (dx, dy) = DIR_TO_VEC[usize::from(agent_dir & 3)];
    let (rx, ry) = (-dy, dx);
    let fwd = (VIEW_SIZE - 1) as i32 - vy as i32;
    let side = vx as i32 - (VIEW_SIZE / 2) as i32;
    (
        agent_pos.0 + dx * fwd + rx * side,
        agent_pos.1 + dy * fwd + ry * side,
    )
}

/// View cell of world position `cell_in_world`, if it lies inside the view square
/// (MiniGrid's `relative_coords`).
pub fn view_from_world(agent_pos: Pos, agent_dir: u8, cell_in_world: Pos) -> Option<ViewCell> {
    let (dx, dy) = DIR_TO_VEC[usize::from(agent_dir & 3)];
    let (rx, ry) = (-dy, dx);
    let (lx, ly) = (cell_in_world.0 - agent_pos.0, cell_in_world.1 - agent_pos.1);
    let vx = rx * lx + ry * ly + (VIEW_SIZE / 2) as i32;
    let vy = (VIEW_SIZE - 1) as i32 - (dx * lx + dy * ly);
    let range = 0..VIEW_SIZE as i32;
    (range.contains(&vx) && range.contains(&vy)).then_some((vx as usize, vy as usize))
}

/// MiniGrid's `Grid.process_vis`: a two-sweep flood from the agent's row upwards, copied
/// loop for loop, diagonal leak included (a lone wall straight ahead does not hide the cell
/// behind it). `cells[vx][vy]` is the rotated view slice.
pub fn process_vis(cells: &[[Cell; VIEW_SIZE]; VIEW_SIZE]) -> [[bool; VIEW_SIZE]; VIEW_SIZE] {
    const W: usize = VIEW_SIZE;
    let mut mask = [[false; W]; W];
    mask[AGENT_IN_VIEW.0][AGENT_IN_VIEW.1] = true;
    let opaque = |i: usize, j: usize| cells[i][j].is_some_and(|c: WorldObj| !c.see_behind());
    for j in (0..W).rev() {
        for i in 0..W - 1 {
            if !mask[i][j] || opaque(i, j) {
                continue;
            }
            mask[i + 1][j] = true;
            if j > 0 {
                mask[i + 1][j - 1] = true;
                mask[i][j - 1] = true;
            }
        }
        for i in (1..W).rev() {
            if !mask[i][j] || opaque(i, j) {
                continue;
            }
            mask[i - 1][j] = true;
            if j > 0 {
                mask[i - 1][j - 1] = true;
                mask[i][j - 1] = true;
            }
        }
    }
    mask
}

/// The rotated 7×7 slice of the world the agent looks at; cells outside the grid are walls.
pub fn view_cells(grid: &Grid, agent_pos: Pos, agent_dir: u8) -> [[Cell; VIEW_SIZE]; VIEW_SIZE] {
    let mut cells = [[None; VIEW_SIZE]; VIEW_SIZE];
    for (vx, col) in cells.iter_mut().enumerate() {
        for (vy, cell) in col.iter_mut().enumerate() {
            *cell = grid.get_or_wall(world_from_view(agent_pos, agent_dir, (vx, vy)));
        }
    }
    cells
}

/// MiniGrid's `gen_obs`: slice, visibility, then the carried object (or nothing) at the
/// agent's cell, encoded.
pub fn observe(
    grid: &Grid,
    agent_pos: Pos,
    agent_dir: u8,
    carrying: Option<WorldObj>,
) -> Observation {
    let mut cells = view_cells(grid, agent_pos, agent_dir);
    let mask = process_vis(&cells);
    cells[AGENT_IN_VIEW.0][AGENT_IN_VIEW.1] = carrying;
    let mut image = [[[0u8; 3]; VIEW_SIZE]; VIEW_SIZE];
    for vx in 0..VIEW_SIZE {
        for vy in 0..VIEW_SIZE {
            if mask[vx][vy] {
                image[vx][vy] = encode_cell(&cells[vx][vy]);
            }
        }
    }
    Observation { image }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::object::{Color, ObjectKind};

    #[test]
    fn view_world_round_trip_every_direction() {
        for dir in 0..4 {
            for vx in 0..VIEW_SIZE {
                for vy in 0..VIEW_SIZE {
                    let w = world_from_view((10, 10), dir, (vx, vy));
                    assert_eq!(view_from_world((10, 10), dir, w), Some((vx, vy)));
                }
            }
            // The cell behind the agent is never in view.
            let (dx, dy) = DIR_TO_VEC[usize::from(dir)];
            assert_eq!(view_from_world((10, 10), dir, (10 - dx, 10 - dy)), None);
        }
        // dir 3 (up): world = (ax + vx − 3, ay − 6 + vy).
        assert_eq!(world_from_view((4, 8), 3, (0, 0)), (1, 2));
        // dir 0 (right): world = (ax + 6 − vy, ay + vx − 3).
        assert_eq!(world_from_view((4, 8), 0, (0, 0)), (10, 5));
    }

    #[test]
    fn lone_wall_ahead_does_not_hide_the_cell_behind() {
        let mut cells = [[None; VIEW_SIZE]; VIEW_SIZE];
        cells[3][5] = Some(WorldObj::new(ObjectKind::Wall, Color::Grey, 0));
        cells[3][4] = Some(WorldObj::new(ObjectKind::Ball, Color::Red, 1));
        let mask = process_vis(&cells);
        assert!(mask[3][5] && mask[3][4]);
    }

    #[test]
    fn a_wall_row_hides_what_is_behind_it() {
        let mut cells = [[None; VIEW_SIZE]; VIEW_SIZE];
        for col in &mut cells {
            col[4] = Some(WorldObj::new(ObjectKind::Wall, Color::Grey, 0));
        }
        let mask = process_vis(&cells);
        for (vx, col) in mask.iter().enumerate() {
            assert!(col[4], "wall at ({vx}, 4) is visible");
            for (vy, seen) in col.iter().enumerate().take(4) {
                assert!(!seen, "({vx}, {vy}) behind the wall row is hidden");
            }
        }
    }
}
