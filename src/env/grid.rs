//! The world grid: x-major, `y` grows downward, `None` for an empty cell.

use super::object::{Cell, Color, ObjectKind, WorldObj};

/// A cell position in the world, `(x, y)`; `y` grows downward.
pub type Pos = (i32, i32);

/// MiniGrid's `DIR_TO_VEC`: 0 = right (+x), 1 = down (+y), 2 = left (−x), 3 = up (−y).
pub const DIR_TO_VEC: [Pos; 4] = [(1, 0), (0, 1), (-1, 0), (0, -1)];

/// RoomGrid's geometry: `num_cols × num_rows` rooms of `room_size` cells a side (walls
/// included), neighbours sharing a wall. A one-room level is 1 × 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Rooms {
    /// Side of one room, walls included.
    pub room_size: i32,
    /// Rooms per row (x).
    pub num_cols: i32,
    /// Rooms per column (y).
    pub num_rows: i32,
}

impl Rooms {
    /// One room filling a `width × height` grid.
    pub fn single(width: usize, height: usize) -> Self {
        Self {
            room_size: width.max(height) as i32,
            num_cols: 1,
            num_rows: 1,
        }
    }

    /// Grid width and height: `(room_size − 1) · n + 1`.
    pub fn grid_size(self) -> (usize, usize) {
        (
            ((self.room_size - 1) * self.num_cols + 1) as usize,
            ((self.room_size - 1) * self.num_rows + 1) as usize,
        )
    }

    /// The grid and the room layout as `env list` and the reports name them: `("22×22",
    /// "3×3")` (width × height walls included, columns × rows).
    pub fn layout_names(self) -> (String, String) {
        let (w, h) = self.grid_size();
        (
            format!("{w}×{h}"),
            format!("{}×{}", self.num_cols, self.num_rows),
        )
    }

    /// `room_from_pos`: the room `(i, j)` holding `pos` (clamped to the grid's rooms, where
    /// Python would assert).
    pub fn room_of(self, (x, y): Pos) -> (i32, i32) {
        let step = (self.room_size - 1).max(1);
        (
            (x.max(0) / step).min(self.num_cols - 1),
            (y.max(0) / step).min(self.num_rows - 1),
        )
    }

    /// `Room.pos_inside`: whether `pos` lies in room `(i, j)`'s square, walls included.
    pub fn pos_inside(self, (i, j): (i32, i32), (x, y): Pos) -> bool {
        let (tx, ty) = (i * (self.room_size - 1), j * (self.room_size - 1));
        x >= tx && y >= ty && x < tx + self.room_size && y < ty + self.room_size
    }
}

/// The fixed arrays' size: grids whose padding by a wall on every side fits it are
/// flood-filled on fixed arrays (every BabyAI grid: BossLevel's 22 × 22 pads to 576).
const WIDE_PADDED: usize = 640;

/// How far the view codes extend past each side of the grid: the view reaches 6 cells ahead.
pub(crate) const VIEW_PAD: i32 = 6;

/// The width × height world grid of MiniGrid (`grid[x][y]`).
#[derive(Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(from = "GridCells", into = "GridCells")]
pub struct Grid {
    width: i32,
    height: i32,
    /// Cells in x-major order: index `x * height + y`, like numpy's `(W, H)` arrays.
    cells: Vec<Cell>,
    /// Each cell's [`view_code`](super::view::view_code), x-major, on a grid padded by
    /// [`VIEW_PAD`] walls on every side: the observation reads any view without bounds
    /// checks or encoding. Kept in step with `cells` by every write; empty when the
    /// dimensions are inconsistent.
    codes: Vec<u32>,
}

/// What a grid serialises as: its dimensions and cells.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
#[serde(rename = "Grid")]
struct GridCells {
    width: i32,
    height: i32,
    cells: Vec<Cell>,
}

impl From<GridCells> for Grid {
    fn from(g: GridCells) -> Self {
        let mut grid = Self {
            width: g.width,
            height: g.height,
            cells: g.cells,
            codes: Vec::new(),
        };
        // Any shape whose cells are all there gets codes (the padding is then at most
        // 12·(w + h + 12) more entries); `is_consistent` still bounds the dimensions.
        let shape_ok = grid.width >= 1
            && grid.height >= 1
            && grid.cells.len() as u64 == grid.width as u64 * grid.height as u64;
        if shape_ok {
            grid.codes = grid.padded_codes();
        }
        grid
    }
}

impl From<Grid> for GridCells {
    fn from(g: Grid) -> Self {
        Self {
            width: g.width,
            height: g.height,
            cells: g.cells,
        }
    }
}

impl std::fmt::Debug for Grid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Grid")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("cells", &self.cells)
            .finish_non_exhaustive()
    }
}

impl Grid {
    /// An empty grid (no walls).
    pub fn new(width: usize, height: usize) -> Self {
        GridCells {
            width: width as i32,
            height: height as i32,
            cells: vec![None; width * height],
        }
        .into()
    }

    /// A grid of no cells, without the work [`Grid::new`] does to check a shape: the
    /// placeholder a generator leaves where it hands its grid on.
    pub const fn empty() -> Self {
        Self {
            width: 0,
            height: 0,
            cells: Vec::new(),
            codes: Vec::new(),
        }
    }

    /// The walls of `rooms` (every room's outer ring, shared between neighbours), with ids
    /// from `next_id` in x-major order: `RoomGrid._gen_grid`'s grid before any door.
    pub fn room_walls(rooms: Rooms, next_id: &mut u32) -> Self {
        let (w, h) = rooms.grid_size();
        let step = (rooms.room_size - 1).max(1) as usize;
        let mut cells = vec![None; w * h];
        for x in 0..w {
            for y in 0..h {
                if x % step == 0 || y % step == 0 {
                    cells[x * h + y] = Some(WorldObj::new(ObjectKind::Wall, Color::Grey, *next_id));
                    *next_id += 1;
                }
            }
        }
        GridCells {
            width: w as i32,
            height: h as i32,
            cells,
        }
        .into()
    }

    /// The view codes of the padded grid, from `cells`.
    fn padded_codes(&self) -> Vec<u32> {
        let (pw, ph) = self.padded_dims();
        let outside =
            super::view::view_code(Some(WorldObj::new(ObjectKind::Wall, Color::Grey, u32::MAX)));
        let mut codes = vec![outside; (pw * ph) as usize];
        for (i, cell) in self.cells.iter().enumerate() {
            let i = i as i32;
            let (x, y) = (i / self.height, i % self.height);
            codes[self.padded_index((x, y))] = super::view::view_code(*cell);
        }
        codes
    }

    /// Width and height of the padded code grid.
    #[inline]
    fn padded_dims(&self) -> (i32, i32) {
        (self.width + 2 * VIEW_PAD, self.height + 2 * VIEW_PAD)
    }

    /// Index in the padded code grid of `pos`, which lies within [`VIEW_PAD`] of the grid.
    #[inline]
    fn padded_index(&self, (x, y): Pos) -> usize {
        ((x + VIEW_PAD) * (self.height + 2 * VIEW_PAD) + y + VIEW_PAD) as usize
    }

    /// The padded view codes, their index of `pos` (inside the grid) and the index step of a
    /// move by `(dx, dy)`: what [`crate::env::view::observe`] walks.
    #[inline]
    pub(crate) fn view_codes(&self, pos: Pos) -> Option<(&[u32], usize)> {
        (self.contains(pos) && !self.codes.is_empty())
            .then(|| (self.codes.as_slice(), self.padded_index(pos)))
    }

    /// The padded index offset of a move by `(dx, dy)`.
    #[inline]
    pub(crate) fn view_stride(&self, (dx, dy): Pos) -> isize {
        (dx * (self.height + 2 * VIEW_PAD) + dy) as isize
    }

    /// Width in cells.
    pub fn width(&self) -> usize {
        self.width as usize
    }

    /// Height in cells.
    pub fn height(&self) -> usize {
        self.height as usize
    }

    /// Whether the dimensions are a room this crate can hold (1..=256 per side) and the cell
    /// vector has one entry per cell: what a deserialised grid must be checked for.
    pub fn is_consistent(&self) -> bool {
        self.cells_consistent() && {
            let (pw, ph) = self.padded_dims();
            self.codes.len() == (pw * ph) as usize
        }
    }

    /// Dimensions in range and one cell per position.
    fn cells_consistent(&self) -> bool {
        (1..=256).contains(&self.width)
            && (1..=256).contains(&self.height)
            && self.cells.len() == (self.width * self.height) as usize
    }

    /// Whether `pos` lies inside the grid.
    #[inline]
    pub fn contains(&self, (x, y): Pos) -> bool {
        x >= 0 && y >= 0 && x < self.width && y < self.height
    }

    #[inline]
    fn index(&self, (x, y): Pos) -> usize {
        (x * self.height + y) as usize
    }

    /// The cell at `pos`; `None` for empty cells and for positions outside the grid.
    #[inline]
    pub fn get(&self, pos: Pos) -> Cell {
        if self.contains(pos) {
            self.cells[self.index(pos)]
        } else {
            None
        }
    }

    /// The cell at `pos`, treating positions outside the grid as walls (`Grid.slice` does).
    #[inline]
    pub fn get_or_wall(&self, pos: Pos) -> Cell {
        if self.contains(pos) {
            self.cells[self.index(pos)]
        } else {
            Some(WorldObj::new(ObjectKind::Wall, Color::Grey, u32::MAX))
        }
    }

    /// Writes `cell` at `pos`; positions outside the grid are ignored.
    #[inline]
    pub fn set(&mut self, pos: Pos, cell: Cell) {
        if self.contains(pos) {
            let i = self.index(pos);
            self.cells[i] = cell;
            let j = self.padded_index(pos);
            if let Some(code) = self.codes.get_mut(j) {
                *code = super::view::view_code(cell);
            }
        }
    }

    /// Walls on the outer ring, as `RoomGrid` builds a 1×1 room.
    pub fn wall_ring(&mut self, next_id: &mut u32) {
        for x in 0..self.width {
            for y in 0..self.height {
                if x == 0 || y == 0 || x == self.width - 1 || y == self.height - 1 {
                    self.set(
                        (x, y),
                        Some(WorldObj::new(ObjectKind::Wall, Color::Grey, *next_id)),
                    );
                    *next_id += 1;
                }
            }
        }
    }

    /// Every object but the walls, with its position, in x-major order: what a description
    /// of a key, ball, box or door can match, gathered once where many descriptions are tried
    /// on one grid (a big level's instruction generation scans it dozens of times).
    pub fn objects_but_walls(&self) -> Vec<(Pos, WorldObj)> {
        // Column by column rather than through `objects`: no division per cell, walls (most
        // of a room grid's objects) skipped before their position is formed, and one buffer.
        let mut out = Vec::with_capacity(32);
        let h = self.height.max(1) as usize;
        for (x, column) in self.cells.chunks(h).enumerate() {
            for (y, cell) in column.iter().enumerate() {
                if let Some(o) = cell
                    && o.kind != ObjectKind::Wall
                {
                    out.push(((x as i32, y as i32), *o));
                }
            }
        }
        out
    }

    /// Every non-empty cell with its position, in x-major order (MiniGrid's scan order).
    pub fn objects(&self) -> impl Iterator<Item = (Pos, WorldObj)> + '_ {
        self.cells.iter().enumerate().filter_map(move |(i, c)| {
            c.map(|o| {
                let i = i as i32;
                ((i / self.height, i % self.height), o)
            })
        })
    }

    /// The position of the object with identity `id`, if it is in the grid.
    pub fn find_id(&self, id: u32) -> Option<Pos> {
        self.objects().find(|(_, o)| o.id == id).map(|(p, _)| p)
    }

    /// MiniGrid's `Grid.encode()`: `[x][y] = (type, colour, state)`, the agent not included.
    pub fn encode(&self) -> Vec<Vec<[u8; 3]>> {
        (0..self.width)
            .map(|x| {
                (0..self.height)
                    .map(|y| super::object::encode_cell(&self.get((x, y))))
                    .collect()
            })
            .collect()
    }

    /// `check_objs_reachable` (see [`crate::env::level::all_reachable`]) on cell indices: a
    /// flood fill from `start` over empty cells and doors; a non-door object is reached but
    /// not expanded; true when every non-wall object was reached.
    pub fn all_objects_reachable(&self, start: Pos) -> bool {
        if !self.contains(start) {
            return false;
        }
        let h = self.height as usize;
        let n = self.cells.len();
        let first = self.index(start);
        if n <= 64 {
            return self.all_reachable_bits(first);
        }
        if (self.width as usize + 2) * (h + 2) <= WIDE_PADDED {
            return self.all_reachable_wide(first);
        }
        let mut seen = vec![false; n];
        let mut stack = Vec::with_capacity(64);
        seen[first] = true;
        stack.push(first);
        while let Some(i) = stack.pop() {
            if i != first && self.cells[i].is_some_and(|o| o.kind != ObjectKind::Door) {
                continue;
            }
            let y = i % h;
            // x ± 1 is i ± h; bounds follow from the index range, y ± 1 from the column.
            let mut visit = |j: usize| {
                if !seen[j] && self.cells[j].is_none_or(|o| o.kind != ObjectKind::Wall) {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if i + h < n {
                visit(i + h);
            }
            if i >= h {
                visit(i - h);
            }
            if y + 1 < h {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - 1);
            }
        }
        self.cells
            .iter()
            .zip(&seen)
            .all(|(c, s)| *s || c.is_none_or(|o| o.kind == ObjectKind::Wall))
    }

    /// [`Self::all_objects_reachable`] for grids that pad to at most [`WIDE_PADDED`] cells
    /// (every BabyAI grid, BossLevel's 22 × 22 included): the same fill on fixed arrays, stopping as
    /// soon as every object has been reached.
    fn all_reachable_wide(&self, first: usize) -> bool {
        const WALL: u8 = 0;
        const EMPTY: u8 = 1;
        const DOOR: u8 = 2;
        const OBJECT: u8 = 3;
        // Columns padded with a wall above and below, and a wall column on each side: every
        // neighbour index is in range and no row test is needed.
        let h = self.height as usize;
        let ph = h + 2;
        let mut kind = [WALL; WIDE_PADDED];
        let mut left = 0usize;
        for (column, padded) in self
            .cells
            .chunks_exact(h)
            .zip(kind[ph..].chunks_exact_mut(ph))
        {
            for (c, k) in column.iter().zip(&mut padded[1..]) {
                *k = match c {
                    None => EMPTY,
                    Some(o) if o.kind == ObjectKind::Wall => WALL,
                    Some(o) if o.kind == ObjectKind::Door => DOOR,
                    Some(_) => OBJECT,
                };
                left += usize::from(*k >= DOOR);
            }
        }
        let first = (first / h + 1) * ph + first % h + 1;
        let mut seen = [false; WIDE_PADDED];
        let mut stack = [0u16; WIDE_PADDED];
        seen[first] = true;
        left -= usize::from(kind[first] >= DOOR);
        stack[0] = first as u16;
        let mut top = 1;
        while top > 0 && left > 0 {
            top -= 1;
            let i = usize::from(stack[top]);
            if i != first && kind[i] == OBJECT {
                continue;
            }
            for j in [i + ph, i - ph, i + 1, i - 1] {
                if !seen[j] && kind[j] != WALL {
                    seen[j] = true;
                    left -= usize::from(kind[j] >= DOOR);
                    stack[top] = j as u16;
                    top += 1;
                }
            }
        }
        left == 0
    }

    /// [`Self::all_objects_reachable`] for grids of at most 64 cells (the paper's 8×8 room),
    /// as a flood fill on bit masks: each round grows the reached set by one step in all four
    /// directions at once.
    fn all_reachable_bits(&self, first: usize) -> bool {
        let h = self.height as usize;
        let bit = |i: usize| 1u64 << i;
        let (mut wall, mut expands, mut objects) = (0u64, 0u64, 0u64);
        let (mut bottom, mut top) = (0u64, 0u64);
        for (i, c) in self.cells.iter().enumerate() {
            match c {
                None => expands |= bit(i),
                Some(o) if o.kind == ObjectKind::Wall => wall |= bit(i),
                Some(o) => {
                    objects |= bit(i);
                    if o.kind == ObjectKind::Door {
                        expands |= bit(i);
                    }
                }
            }
            if i % h == 0 {
                bottom |= bit(i);
            }
            if i % h == h - 1 {
                top |= bit(i);
            }
        }
        let valid = u64::MAX >> (64 - self.cells.len());
        let open = valid & !wall;
        let mut reached = bit(first);
        loop {
            // Reached empty cells and doors spread, and the start cell whatever it holds.
            let src = (reached & expands) | bit(first);
            let grown = ((src & !top) << 1)
                | ((src & !bottom) >> 1)
                | src.checked_shl(h as u32).unwrap_or(0)
                | src.checked_shr(h as u32).unwrap_or(0);
            let next = reached | (grown & open);
            if next == reached {
                return objects & !reached == 0;
            }
            reached = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// `objects_but_walls` lists what a plain scan of `objects` keeps (every object but the
    /// walls, x-major), on grids of many shapes, before and after writes, with and without
    /// cells a grid holds only when built directly (objects of the unseen or empty type).
    #[test]
    fn objects_but_walls_is_the_scan_without_walls() {
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        let sizes = [
            (1, 1),
            (3, 5),
            (7, 13),
            (13, 7),
            (25, 25),
            (5, 64),
            (4, 65),
            (3, 130),
        ];
        for ((w, h), typeless) in sizes.into_iter().flat_map(|s| [(s, false), (s, true)]) {
            let mut grid = Grid::new(w, h);
            for round in 0..4 {
                let typeless = typeless && round < 3;
                for _ in 0..(w * h / 2).max(1) {
                    let pos = (rng.random_range(0..w as i32), rng.random_range(0..h as i32));
                    let cell = match rng.random_range(0..4) {
                        0 => None,
                        1 => Some(WorldObj::new(ObjectKind::Wall, Color::Grey, 0)),
                        _ => {
                            let kinds = if typeless {
                                &ObjectKind::ALL[..]
                            } else {
                                &ObjectKind::ALL[2..]
                            };
                            let kind = kinds[rng.random_range(0..kinds.len())];
                            let color = Color::ALL[rng.random_range(0..Color::ALL.len())];
                            Some(WorldObj::new(kind, color, rng.random_range(0..1000)))
                        }
                    };
                    grid.set(pos, cell);
                }
                let want: Vec<(Pos, WorldObj)> = grid
                    .objects()
                    .filter(|(_, o)| o.kind != ObjectKind::Wall)
                    .collect();
                assert_eq!(grid.objects_but_walls(), want, "{w} × {h}, round {round}");
            }
        }
    }
}
