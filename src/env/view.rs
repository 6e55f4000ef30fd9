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

/// MiniGrid's `Grid.process_vis`: a two-sweep flood from the agent's row upwards, diagonal
/// leak included (a lone wall straight ahead does not hide the cell behind it). `cells[vx][vy]`
/// is the rotated view slice.
pub fn process_vis(cells: &[[Cell; VIEW_SIZE]; VIEW_SIZE]) -> [[bool; VIEW_SIZE]; VIEW_SIZE] {
    let mut transparent = [0u8; VIEW_SIZE];
    for (vx, col) in cells.iter().enumerate() {
        for (vy, cell) in col.iter().enumerate() {
            transparent[vy] |= u8::from(see_behind(*cell)) << vx;
        }
    }
    let rows = visibility_rows(transparent);
    std::array::from_fn(|vx| std::array::from_fn(|vy| rows[vy] >> vx & 1 == 1))
}

#[inline]
fn see_behind(cell: Cell) -> bool {
    cell.is_none_or(|c: WorldObj| c.see_behind())
}

/// `process_vis` on bit rows: `transparent[vy]` has bit `vx` set where light passes; the
/// result has bit `vx` of row `vy` set where the cell is visible.
///
/// MiniGrid's loops visit each row from the agent's upwards, first left to right (a visible,
/// transparent cell `i` lights `i + 1` in its row and `i`, `i + 1` in the row ahead), then right
/// to left (lighting `i − 1` and `i`, `i − 1`). A cell's mask cannot change after its visit in
/// either sweep, so each sweep is the fixpoint of one shift, and what it lights ahead follows
/// from that fixpoint. The loop-for-loop port is the reference in this module's tests.
#[inline]
fn visibility_rows(transparent: [u8; VIEW_SIZE]) -> [u8; VIEW_SIZE] {
    // Columns 0..=5 light rightwards, columns 1..=6 leftwards.
    const RIGHTWARD: u8 = 0b011_1111;
    const LEFTWARD: u8 = 0b111_1110;
    let mut mask = [0u8; VIEW_SIZE];
    mask[AGENT_IN_VIEW.1] = 1 << AGENT_IN_VIEW.0;
    for j in (0..VIEW_SIZE).rev() {
        let t = transparent[j];
        let mut fwd = mask[j];
        loop {
            let next = fwd | (fwd & t & RIGHTWARD) << 1;
            if next == fwd {
                break;
            }
            fwd = next;
        }
        let mut back = fwd;
        loop {
            let next = back | (back & t & LEFTWARD) >> 1;
            if next == back {
                break;
            }
            back = next;
        }
        mask[j] = back;
        if j > 0 {
            let lit_fwd = fwd & t & RIGHTWARD;
            let lit_back = back & t & LEFTWARD;
            mask[j - 1] |= lit_fwd | lit_fwd << 1 | lit_back | lit_back >> 1;
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

/// A cell as the observation reads it: its `(type, colour, state)` encoding in the low three
/// bytes and, in bit 24, whether light passes through it.
#[inline]
pub(crate) fn view_code(cell: Cell) -> u32 {
    let [t, c, s] = encode_cell(&cell);
    u32::from_le_bytes([t, c, s, u8::from(see_behind(cell))])
}

/// MiniGrid's `gen_obs`: slice, visibility, then the carried object (or nothing) at the
/// agent's cell, encoded.
///
/// The grid keeps every cell's encoding on a wall-padded copy ([`view_code`]), so the slice
/// is 49 loads; the visibility sweep then blanks the hidden cells. That is most of what an
/// environment step costs.
pub fn observe(
    grid: &Grid,
    agent_pos: Pos,
    agent_dir: u8,
    carrying: Option<WorldObj>,
) -> Observation {
    observe_seeing(grid, agent_pos, agent_dir, carrying, false)
}

/// [`observe`] with MiniGrid's `see_through_walls`: when set (Empty, Fetch, GoToDoor,
/// Dynamic-Obstacles, …), no visibility sweep, every cell of the slice is shown.
pub fn observe_seeing(
    grid: &Grid,
    agent_pos: Pos,
    agent_dir: u8,
    carrying: Option<WorldObj>,
    see_through_walls: bool,
) -> Observation {
    let Some((codes, at_agent)) = grid.view_codes(agent_pos) else {
        return observe_slice(grid, agent_pos, agent_dir, carrying, see_through_walls);
    };
    let (dx, dy) = DIR_TO_VEC[usize::from(agent_dir & 3)];
    let ahead = grid.view_stride((dx, dy));
    // Moving right in the view is `(−dy, dx)` in the world.
    let right = grid.view_stride((-dy, dx));
    let origin =
        at_agent as isize + ahead * (VIEW_SIZE - 1) as isize - right * (VIEW_SIZE / 2) as isize;
    let mut image = [[[0u8; 3]; VIEW_SIZE]; VIEW_SIZE];
    let mut transparent = [0u8; VIEW_SIZE];
    let mut row_start = origin;
    for (vy, bits) in transparent.iter_mut().enumerate() {
        let mut at = row_start;
        for (vx, col) in image.iter_mut().enumerate() {
            let [t, c, s, light] = codes[at as usize].to_le_bytes();
            *bits |= light << vx;
            col[vy] = [t, c, s];
            at += right;
        }
        row_start -= ahead;
    }
    finish_observation(image, transparent, carrying, see_through_walls)
}

/// [`observe`] the obvious way, for an agent outside the grid (snapshots are checked, but the
/// function is public).
fn observe_slice(
    grid: &Grid,
    agent_pos: Pos,
    agent_dir: u8,
    carrying: Option<WorldObj>,
    see_through_walls: bool,
) -> Observation {
    let cells = view_cells(grid, agent_pos, agent_dir);
    let mut image = [[[0u8; 3]; VIEW_SIZE]; VIEW_SIZE];
    let mut transparent = [0u8; VIEW_SIZE];
    for (vx, col) in cells.iter().enumerate() {
        for (vy, cell) in col.iter().enumerate() {
            transparent[vy] |= u8::from(see_behind(*cell)) << vx;
            image[vx][vy] = encode_cell(cell);
        }
    }
    finish_observation(image, transparent, carrying, see_through_walls)
}

/// Blanks the cells the sweep hides and puts the carried object at the agent's cell.
#[inline]
fn finish_observation(
    mut image: [[[u8; 3]; VIEW_SIZE]; VIEW_SIZE],
    transparent: [u8; VIEW_SIZE],
    carrying: Option<WorldObj>,
    see_through_walls: bool,
) -> Observation {
    if !see_through_walls {
        let visible = visibility_rows(transparent);
        for (vx, col) in image.iter_mut().enumerate() {
            for (vy, code) in col.iter_mut().enumerate() {
                if visible[vy] >> vx & 1 == 0 {
                    *code = [0; 3];
                }
            }
        }
    }
    image[AGENT_IN_VIEW.0][AGENT_IN_VIEW.1] = encode_cell(&carrying);
    Observation { image }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::object::{Color, DoorState, ObjectKind};

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

    /// MiniGrid's `Grid.process_vis`, copied loop for loop.
    fn process_vis_loops(cells: &[[Cell; VIEW_SIZE]; VIEW_SIZE]) -> [[bool; VIEW_SIZE]; VIEW_SIZE] {
        const W: usize = VIEW_SIZE;
        let mut mask = [[false; W]; W];
        mask[AGENT_IN_VIEW.0][AGENT_IN_VIEW.1] = true;
        let opaque = |i: usize, j: usize| !see_behind(cells[i][j]);
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

    /// The observation built the obvious way: slice, loop-for-loop visibility, encode.
    fn observe_reference(
        grid: &Grid,
        agent_pos: Pos,
        agent_dir: u8,
        carrying: Option<WorldObj>,
    ) -> Observation {
        let mut cells = view_cells(grid, agent_pos, agent_dir);
        let mask = process_vis_loops(&cells);
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

    /// A random object: walls often (they are what hides cells), doors in all three states.
    fn random_obj(rng: &mut impl rand::Rng, id: u32) -> WorldObj {
        let kinds = [
            ObjectKind::Wall,
            ObjectKind::Wall,
            ObjectKind::Door,
            ObjectKind::Key,
            ObjectKind::Ball,
            ObjectKind::Box,
        ];
        let mut obj = WorldObj::new(
            kinds[rng.random_range(0..kinds.len())],
            Color::from_index(rng.random_range(0..6)).unwrap(),
            id,
        );
        if obj.kind == ObjectKind::Door {
            obj.state =
                [DoorState::Open, DoorState::Closed, DoorState::Locked][rng.random_range(0..3)];
        }
        obj
    }

    #[test]
    fn bit_sweep_is_minigrid_loops_on_random_views() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for case in 0..20_000 {
            let density = rng.random_range(0.0..0.8);
            let cells: [[Cell; VIEW_SIZE]; VIEW_SIZE] = std::array::from_fn(|_| {
                std::array::from_fn(|_| rng.random_bool(density).then(|| random_obj(&mut rng, 1)))
            });
            assert_eq!(
                process_vis(&cells),
                process_vis_loops(&cells),
                "case {case}"
            );
        }
    }

    #[test]
    fn fused_observe_is_slice_sweep_encode_on_random_worlds() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        for case in 0..5_000 {
            let (w, h) = (rng.random_range(1..14), rng.random_range(1..14));
            let mut grid = Grid::new(w, h);
            let density = rng.random_range(0.0..0.7);
            for x in 0..w as i32 {
                for y in 0..h as i32 {
                    if rng.random_bool(density) {
                        grid.set((x, y), Some(random_obj(&mut rng, (x * 100 + y) as u32)));
                    }
                }
            }
            // Now and then outside the grid, which takes the slice path.
            let pos = (
                rng.random_range(-1..w as i32 + 1),
                rng.random_range(-1..h as i32 + 1),
            );
            let dir = rng.random_range(0..4);
            let carrying = rng.random_bool(0.3).then(|| random_obj(&mut rng, 9_999));
            assert_eq!(
                observe(&grid, pos, dir, carrying),
                observe_reference(&grid, pos, dir, carrying),
                "case {case}: {w}×{h}, agent {pos:?} dir {dir}"
            );
        }
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
