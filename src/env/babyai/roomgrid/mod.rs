//! minigrid's `RoomGrid` and the parts of `MiniGridEnv` a level's generation calls
//! (`place_obj`, `place_agent`, the `_rand_*` helpers), drawing from numpy's stream in the
//! same order as Python.

use crate::env::grid::{DIR_TO_VEC, Grid, Pos, Rooms};
use crate::env::object::{Color, DoorState, ObjectId, ObjectKind, WorldObj};
use crate::env::rng::NumpyRng;

mod doors;

thread_local! {
    /// Wall-only grids by geometry, with the next free id (see [`Gen::gen_grid`]).
    static WALLS: std::cell::RefCell<Vec<(Rooms, Grid, ObjectId)>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// `COLOR_NAMES`, which minigrid sorts: not in colour-code order.
pub const COLOR_NAMES: [Color; 6] = [
    Color::Blue,
    Color::Green,
    Color::Grey,
    Color::Purple,
    Color::Red,
    Color::Yellow,
];

/// The distractor types of `add_object` / `add_distractors`, in their order.
pub const DISTRACTOR_TYPES: [ObjectKind; 3] = [ObjectKind::Key, ObjectKind::Ball, ObjectKind::Box];

/// Why one attempt at a level was thrown away; minigrid then regenerates the whole level,
/// drawing on from the same stream.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Retry {
    /// `RejectSampling`: the level broke one of its rules.
    Reject(&'static str),
    /// `RecursionError`: a placement loop ran out of tries.
    Recursion(&'static str),
    /// A loop minigrid never leaves (no draw can end it): generation stops here with an
    /// error instead of hanging as Python does.
    Endless(&'static str),
}

/// A wall slot of a room: nothing, a removed wall (`True` in Python), or a door.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// A wall.
    Wall,
    /// `remove_wall` opened it.
    Open,
    /// A door with this id at this cell.
    Door(ObjectId, Pos),
}

impl Slot {
    /// Python's truthiness of `room.doors[k]`.
    fn connects(self) -> bool {
        self != Self::Wall
    }
}

/// `Room`.
#[derive(Clone, Debug)]
pub struct Room {
    /// Top-left cell (a wall).
    pub top: Pos,
    /// `doors[k]`, k = 0 right, 1 down, 2 left, 3 up.
    pub doors: [Slot; 4],
    /// `door_pos[k]`.
    pub door_pos: [Option<Pos>; 4],
    /// `neighbors[k]` as a room index.
    pub neighbors: [Option<usize>; 4],
    /// `locked`.
    pub locked: bool,
}

/// The bit of [`Gen::placed`] that stands for `(kind, color)`.
fn placed_bit(kind: ObjectKind, color: Color) -> u128 {
    1u128 << ((kind as u32) * 8 + color as u32)
}

// The index above stays below 128.
const _: () = assert!(ObjectKind::ALL.len() <= 16 && COLOR_NAMES.len() <= 8);

/// The state a level's `gen_mission` works on.
pub struct Gen {
    /// numpy's stream.
    pub rng: NumpyRng,
    /// The geometry.
    pub rooms: Rooms,
    /// The grid being built.
    pub grid: Grid,
    /// Rooms, row-major: index `j · num_cols + i`.
    pub room_list: Vec<Room>,
    /// `agent_pos` (the grid's centre until the agent is placed).
    pub agent_pos: Pos,
    /// `agent_dir`.
    pub agent_dir: u8,
    /// Next object id.
    pub next_id: ObjectId,
    /// What each box holds.
    pub box_contents: Vec<(ObjectId, WorldObj)>,
    /// `(type, colour)` of every object placed in a room (the union of the rooms' `objs`,
    /// which `add_distractors` reads only as a set), one bit per pair ([`placed_bit`]): the
    /// uniqueness test runs once per draw, dozens of times per level with many objects.
    pub placed: u128,
}

impl Gen {
    /// A generator for `rooms`, seeded as `reset(seed=seed)` seeds minigrid.
    pub fn new(rooms: Rooms, seed: u64) -> Self {
        Self::with_rng(rooms, NumpyRng::new(seed))
    }

    /// A generator drawing from `rng` where it stands (minigrid's `reset()` without a seed).
    pub fn with_rng(rooms: Rooms, rng: NumpyRng) -> Self {
        Self {
            rng,
            rooms,
            // Built by `gen_grid`; an empty grid costs nothing.
            grid: Grid::empty(),
            room_list: Vec::new(),
            agent_pos: (-1, -1),
            agent_dir: 0,
            next_id: 0,
            box_contents: Vec::new(),
            placed: 0,
        }
    }

    /// A new object id.
    pub fn obj(&mut self, kind: ObjectKind, color: Color) -> WorldObj {
        let o = WorldObj::new(kind, color, self.next_id);
        self.next_id += 1;
        o
    }

    /// `_rand_int(low, high)`.
    #[inline]
    pub fn rand_int(&mut self, low: i32, high: i32) -> i32 {
        self.rng.integers(i64::from(low), i64::from(high)) as i32
    }

    /// `_rand_bool()`: `integers(0, 2) == 0`.
    #[inline]
    pub fn rand_bool(&mut self) -> bool {
        self.rng.integers(0, 2) == 0
    }

    /// `_rand_elem(list)`.
    #[inline]
    pub fn rand_elem<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.rng.below(0, items.len())]
    }

    /// `_rand_color()`.
    #[inline]
    pub fn rand_color(&mut self) -> Color {
        self.rand_elem(&COLOR_NAMES)
    }

    /// `_rand_subset(list, n)`: repeated `_rand_elem`, removing each pick.
    pub fn rand_subset<T: Copy>(&mut self, items: &[T], n: usize) -> Vec<T> {
        let mut left = items.to_vec();
        let mut out = Vec::with_capacity(n);
        while out.len() < n && !left.is_empty() {
            let i = self.rng.below(0, left.len());
            out.push(left.remove(i));
        }
        out
    }

    /// Room `(i, j)`'s index.
    pub fn room_index(&self, i: i32, j: i32) -> usize {
        (j * self.rooms.num_cols + i) as usize
    }

    /// `room_from_pos`.
    pub fn room_at(&self, pos: Pos) -> usize {
        let (i, j) = self.rooms.room_of(pos);
        self.room_index(i, j)
    }

    /// `RoomGrid._gen_grid`: walls of every room, door positions (drawn here), the agent at
    /// the centre facing right.
    pub fn gen_grid(&mut self) {
        // The walls are the same for every attempt and every seed of a geometry: copy them
        // from a per-thread template rather than building them (and their view codes) again.
        let rooms = self.rooms;
        self.next_id = WALLS.with(|cache| {
            let mut cache = cache.borrow_mut();
            if let Some((_, grid, n)) = cache.iter().find(|(r, _, _)| *r == rooms) {
                self.grid.clone_from(grid);
                return *n;
            }
            let mut n = 0;
            let grid = Grid::room_walls(rooms, &mut n);
            self.grid.clone_from(&grid);
            if cache.len() >= 16 {
                cache.remove(0);
            }
            cache.push((rooms, grid, n));
            n
        });
        self.box_contents.clear();
        self.placed = 0;
        let rs = self.rooms.room_size;
        let (cols, rows) = (self.rooms.num_cols, self.rooms.num_rows);
        self.room_list.clear();
        for j in 0..rows {
            for i in 0..cols {
                let top = (i * (rs - 1), j * (rs - 1));
                self.room_list.push(Room {
                    top,
                    doors: [Slot::Wall; 4],
                    door_pos: [None; 4],
                    neighbors: [None; 4],
                    locked: false,
                });
            }
        }
        for j in 0..rows {
            for i in 0..cols {
                let r = self.room_index(i, j);
                let top = self.room_list[r].top;
                let (xl, yl) = (top.0 + 1, top.1 + 1);
                let (xm, ym) = (top.0 + rs - 1, top.1 + rs - 1);
                if i < cols - 1 {
                    self.room_list[r].neighbors[0] = Some(self.room_index(i + 1, j));
                    let y = self.rand_int(yl, ym);
                    self.room_list[r].door_pos[0] = Some((xm, y));
                }
                if j < rows - 1 {
                    self.room_list[r].neighbors[1] = Some(self.room_index(i, j + 1));
                    let x = self.rand_int(xl, xm);
                    self.room_list[r].door_pos[1] = Some((x, ym));
                }
                if i > 0 {
                    let n = self.room_index(i - 1, j);
                    self.room_list[r].neighbors[2] = Some(n);
                    self.room_list[r].door_pos[2] = self.room_list[n].door_pos[0];
                }
                if j > 0 {
                    let n = self.room_index(i, j - 1);
                    self.room_list[r].neighbors[3] = Some(n);
                    self.room_list[r].door_pos[3] = self.room_list[n].door_pos[1];
                }
            }
        }
        self.agent_pos = (
            (cols / 2) * (rs - 1) + rs / 2,
            (rows / 2) * (rs - 1) + rs / 2,
        );
        self.agent_dir = 0;
    }

    /// `place_obj(obj, top, size, reject_fn, max_tries)`: a uniform cell of the rectangle
    /// (clipped to the grid) that is empty, not the agent's, and not rejected.
    pub fn place_obj(
        &mut self,
        obj: Option<WorldObj>,
        top: Pos,
        size: (i32, i32),
        reject_next_to: bool,
        max_tries: u32,
    ) -> Result<Pos, Retry> {
        let agent = self.agent_pos;
        let next_to = |(x, y): Pos| (agent.0 - x).abs() + (agent.1 - y).abs() < 2;
        self.place_obj_with(obj, top, size, |p| reject_next_to && next_to(p), max_tries)
    }

    /// `place_obj` with any `reject_fn` (MiniGrid's PutNear rejects cells beside its objects).
    pub fn place_obj_with(
        &mut self,
        obj: Option<WorldObj>,
        top: Pos,
        size: (i32, i32),
        reject: impl Fn(Pos) -> bool,
        max_tries: u32,
    ) -> Result<Pos, Retry> {
        let top = (top.0.max(0), top.1.max(0));
        let (w, h) = (self.grid.width() as i32, self.grid.height() as i32);
        let mut tries = 0u32;
        loop {
            if tries > max_tries {
                return Err(Retry::Recursion("rejection sampling failed in place_obj"));
            }
            tries += 1;
            let x = self.rand_int(top.0, (top.0 + size.0).min(w));
            let y = self.rand_int(top.1, (top.1 + size.1).min(h));
            let pos = (x, y);
            if self.grid.get(pos).is_some() || pos == self.agent_pos || reject(pos) {
                continue;
            }
            self.grid.set(pos, obj);
            return Ok(pos);
        }
    }

    /// `place_in_room(i, j, obj)`.
    pub fn place_in_room(&mut self, i: i32, j: i32, obj: WorldObj) -> Result<Pos, Retry> {
        let r = self.room_index(i, j);
        let (top, rs) = (self.room_list[r].top, self.rooms.room_size);
        let pos = self.place_obj(Some(obj), top, (rs, rs), true, 1000)?;
        self.placed |= placed_bit(obj.kind, obj.color);
        Ok(pos)
    }

    /// `add_object(i, j, kind, color)`: the kind is drawn before the colour.
    pub fn add_object(
        &mut self,
        i: i32,
        j: i32,
        kind: Option<ObjectKind>,
        color: Option<Color>,
    ) -> Result<(WorldObj, Pos), Retry> {
        let kind = match kind {
            Some(k) => k,
            None => self.rand_elem(&DISTRACTOR_TYPES),
        };
        let color = match color {
            Some(c) => c,
            None => self.rand_color(),
        };
        let obj = self.obj(kind, color);
        let pos = self.place_in_room(i, j, obj)?;
        Ok((obj, pos))
    }

    /// `add_door(i, j, door_idx, color, locked)`; sets the room's `locked` to `locked`.
    pub fn add_door(
        &mut self,
        i: i32,
        j: i32,
        door_idx: Option<usize>,
        color: Option<Color>,
        locked: Option<bool>,
    ) -> (WorldObj, Pos) {
        let r = self.room_index(i, j);
        let k = match door_idx {
            Some(k) => k,
            None => loop {
                let k = self.rng.below(0, 4);
                let room = &self.room_list[r];
                if room.neighbors[k].is_some() && room.doors[k] == Slot::Wall {
                    break k;
                }
            },
        };
        let color = match color {
            Some(c) => c,
            None => self.rand_color(),
        };
        let locked = match locked {
            Some(l) => l,
            None => self.rand_bool(),
        };
        self.room_list[r].locked = locked;
        let mut door = self.obj(ObjectKind::Door, color);
        door.state = if locked {
            DoorState::Locked
        } else {
            DoorState::Closed
        };
        // Every caller passes a wall slot with a neighbour (Python asserts it).
        let pos = self.room_list[r].door_pos[k].unwrap_or((0, 0));
        self.grid.set(pos, Some(door));
        self.room_list[r].doors[k] = Slot::Door(door.id, pos);
        if let Some(n) = self.room_list[r].neighbors[k] {
            self.room_list[n].doors[(k + 2) % 4] = Slot::Door(door.id, pos);
        }
        (door, pos)
    }

    /// `remove_wall(i, j, wall_idx)`.
    pub fn remove_wall(&mut self, i: i32, j: i32, k: usize) {
        let r = self.room_index(i, j);
        let (tx, ty) = self.room_list[r].top;
        let s = self.rooms.room_size;
        for t in 1..s - 1 {
            let pos = match k {
                0 => (tx + s - 1, ty + t),
                1 => (tx + t, ty + s - 1),
                2 => (tx, ty + t),
                _ => (tx + t, ty),
            };
            self.grid.set(pos, None);
        }
        self.room_list[r].doors[k] = Slot::Open;
        if let Some(n) = self.room_list[r].neighbors[k] {
            self.room_list[n].doors[(k + 2) % 4] = Slot::Open;
        }
    }

    /// `RoomGrid.place_agent(i, j)`: a free cell of the room and a direction, redrawn while
    /// the agent faces anything but a wall or an empty cell.
    pub fn place_agent(&mut self, i: Option<i32>, j: Option<i32>) -> Result<Pos, Retry> {
        let i = match i {
            Some(i) => i,
            None => self.rand_int(0, self.rooms.num_cols),
        };
        let j = match j {
            Some(j) => j,
            None => self.rand_int(0, self.rooms.num_rows),
        };
        let r = self.room_index(i, j);
        let (top, rs) = (self.room_list[r].top, self.rooms.room_size);
        if self.agent_boxed_in(top, rs) {
            return Err(Retry::Endless(
                "place_agent: every free cell of the room faces an object on all four sides, so minigrid redraws forever",
            ));
        }
        loop {
            self.agent_pos = (-1, -1);
            let pos = self.place_obj(None, top, (rs, rs), false, 1000)?;
            self.agent_pos = pos;
            self.agent_dir = self.rng.below(0, 4) as u8;
            let d = DIR_TO_VEC[usize::from(self.agent_dir)];
            let front = self.grid.get((pos.0 + d.0, pos.1 + d.1));
            if front.is_none_or(|o| o.kind == ObjectKind::Wall) {
                return Ok(pos);
            }
        }
    }

    /// Whether the room at `top` has free cells but none where the agent could face a wall
    /// or an empty cell (then `place_agent`'s `while True` never ends; with no free cell at
    /// all, `place_obj` raises after its tries instead).
    fn agent_boxed_in(&self, top: Pos, rs: i32) -> bool {
        let (w, h) = (self.grid.width() as i32, self.grid.height() as i32);
        let cells = (top.0.max(0)..(top.0 + rs).min(w))
            .flat_map(|x| (top.1.max(0)..(top.1 + rs).min(h)).map(move |y| (x, y)));
        let mut free = cells.filter(|&p| self.grid.get(p).is_none()).peekable();
        if free.peek().is_none() {
            return false;
        }
        !free.any(|(x, y)| {
            DIR_TO_VEC.iter().any(|d| {
                self.grid
                    .get((x + d.0, y + d.1))
                    .is_none_or(|o| o.kind == ObjectKind::Wall)
            })
        })
    }

    /// `place_agent()` in a random room, redrawn while the agent lands in room index `room`
    /// (the levels' locked room; `None`: once).
    pub fn place_agent_outside(&mut self, room: Option<usize>) -> Result<(), Retry> {
        loop {
            self.place_agent(None, None)?;
            if Some(self.room_at(self.agent_pos)) != room {
                return Ok(());
            }
        }
    }

    /// `add_distractors(i, j, num_distractors, all_unique)`: colour drawn before type, the
    /// room drawn per object when not given.
    pub fn add_distractors(
        &mut self,
        i: Option<i32>,
        j: Option<i32>,
        n: usize,
        all_unique: bool,
    ) -> Result<Vec<WorldObj>, Retry> {
        let mut dists = Vec::with_capacity(n);
        self.distractors(i, j, n, all_unique, |o, _| dists.push(o))?;
        Ok(dists)
    }

    /// [`Gen::add_distractors`] with each object's position (for a level that knows every
    /// object of its grid without scanning it).
    pub fn add_distractors_placed(
        &mut self,
        i: Option<i32>,
        j: Option<i32>,
        n: usize,
        all_unique: bool,
    ) -> Result<Vec<(Pos, WorldObj)>, Retry> {
        let mut dists = Vec::with_capacity(n);
        self.distractors(i, j, n, all_unique, |o, pos| dists.push((pos, o)))?;
        Ok(dists)
    }

    /// `add_distractors`' loop, handing each placed object and its position to `keep`.
    fn distractors(
        &mut self,
        i: Option<i32>,
        j: Option<i32>,
        n: usize,
        all_unique: bool,
        mut keep: impl FnMut(WorldObj, Pos),
    ) -> Result<(), Retry> {
        let mut placed = 0;
        while placed < n {
            let color = self.rand_color();
            let kind = self.rand_elem(&DISTRACTOR_TYPES);
            if all_unique && self.placed & placed_bit(kind, color) != 0 {
                continue;
            }
            let ri = match i {
                Some(i) => i,
                None => self.rand_int(0, self.rooms.num_cols),
            };
            let rj = match j {
                Some(j) => j,
                None => self.rand_int(0, self.rooms.num_rows),
            };
            let (dist, pos) = self.add_object(ri, rj, Some(kind), Some(color))?;
            keep(dist, pos);
            placed += 1;
        }
        Ok(())
    }

    /// `check_objs_reachable`: every non-wall object reachable from the agent.
    pub fn objs_reachable(&self) -> bool {
        self.grid.all_objects_reachable(self.agent_pos)
    }

    /// `check_objs_reachable()` raising `RejectSampling`.
    pub fn check_objs_reachable(&self) -> Result<(), Retry> {
        if self.objs_reachable() {
            Ok(())
        } else {
            Err(Retry::Reject("unreachable object"))
        }
    }

    /// The position of the object with id `id` on the grid.
    pub fn pos_of(&self, id: ObjectId) -> Option<Pos> {
        self.grid.find_id(id)
    }

    /// Recolours the object with id `id` on the grid (GoToRedBallGrey greys its distractors).
    pub fn recolor(&mut self, id: ObjectId, color: Color) {
        if let Some(pos) = self.pos_of(id)
            && let Some(mut o) = self.grid.get(pos)
        {
            o.color = color;
            self.grid.set(pos, Some(o));
        }
    }
}
