//! The bot's searches over the grid it has seen: breadth-first paths with its own
//! tie-breaking, the closest matching object, a place to drop what it carries, and how far a
//! wall lies to each side (`_breadth_first_search`, `_shortest_path`, `_find_obj_pos`,
//! `_find_drop_pos`, `_closest_wall_or_door_given_dir` of `baby_ai_bot.py`).

use std::collections::VecDeque;

use crate::env::{Cell, DoorState, Grid, ObjectId, ObjectKind, Pos, World, view_from_world};

use super::GiveUp;

/// No entry yet in a search's `previous_pos`.
const UNVISITED: i32 = -2;
/// A start of the search (`previous_pos[start] = None`).
const ROOT: i32 = -1;

/// What `_shortest_path` returns.
#[derive(Clone, Debug, Default)]
pub(crate) struct ShortPath {
    /// The cells to walk, the agent's own cell left out; `Some(empty)` when the agent's cell
    /// itself is accepted (Python's falsy `[]`), `None` when nothing was found.
    pub path: Option<Vec<Pos>>,
    /// The accepted cell.
    pub finish: Option<Pos>,
    /// Whether the second search, through blockers, ran.
    pub with_blockers: bool,
}

impl ShortPath {
    /// Python's `if path:`: found and not empty.
    pub fn first(&self) -> Option<Pos> {
        self.path.as_ref().and_then(|p| p.first().copied())
    }
}

/// Reusable buffers of one breadth-first search.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
struct Frontier {
    /// `previous_pos`, x-major: the index of the cell it was reached from, [`ROOT`] or
    /// [`UNVISITED`].
    prev: Vec<i32>,
    /// The cells in the order they were entered in `previous_pos` (a dict keeps insertion
    /// order, and the second search starts from them in that order).
    order: Vec<usize>,
    /// `(x, y, dx, dy, from)`.
    queue: VecDeque<(i32, i32, i32, i32, i32)>,
}

/// The grid the bot plans on, what it has seen of it, and its search buffers.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub(crate) struct Planner {
    pub width: i32,
    pub height: i32,
    /// `vis_mask`, x-major: every cell the agent has seen this episode.
    pub vis: Vec<bool>,
    /// Scratch of the searches (emptied by each): not part of the bot's state.
    #[serde(skip)]
    first: Frontier,
    #[serde(skip)]
    second: Frontier,
}

fn out_of_grid() -> GiveUp {
    GiveUp::Broken("the search left the grid".into())
}

impl Planner {
    pub fn new(width: i32, height: i32) -> Self {
        let n = (width.max(0) * height.max(0)) as usize;
        Self {
            width,
            height,
            vis: vec![false; n],
            first: Frontier::default(),
            second: Frontier::default(),
        }
    }

    #[inline]
    pub fn index(&self, (x, y): Pos) -> Option<usize> {
        (x >= 0 && y >= 0 && x < self.width && y < self.height)
            .then(|| (x * self.height + y) as usize)
    }

    #[inline]
    fn pos_of(&self, idx: usize) -> Pos {
        let i = idx as i32;
        (i / self.height, i % self.height)
    }

    /// `vis_mask[pos]`; cells outside the grid were never seen.
    #[inline]
    pub fn seen(&self, pos: Pos) -> bool {
        self.index(pos).is_some_and(|i| self.vis[i])
    }

    /// `_breadth_first_search`: the accepted cell's index, with `frontier.prev` holding the
    /// tree. Cells are marked when taken from the queue, so a cell reached twice keeps its
    /// first way in; going straight on is queued before turning.
    fn bfs(
        frontier: &mut Frontier,
        planner: (&[bool], i32, i32),
        grid: &Grid,
        starts: &mut dyn Iterator<Item = (i32, i32, i32, i32)>,
        accept: &mut dyn FnMut(Pos, Cell) -> bool,
        ignore_blockers: bool,
    ) -> Result<Option<usize>, GiveUp> {
        let (vis, width, height) = planner;
        frontier.prev.clear();
        frontier.prev.resize(vis.len(), UNVISITED);
        frontier.order.clear();
        frontier.queue.clear();
        frontier
            .queue
            .extend(starts.map(|(i, j, di, dj)| (i, j, di, dj, ROOT)));
        while let Some((i, j, di, dj, from)) = frontier.queue.pop_front() {
            if i < 0 || j < 0 || i >= width || j >= height {
                return Err(out_of_grid());
            }
            let idx = (i * height + j) as usize;
            if frontier.prev[idx] != UNVISITED {
                continue;
            }
            let cell = grid.get((i, j));
            frontier.prev[idx] = from;
            frontier.order.push(idx);
            if accept((i, j), cell) {
                return Ok(Some(idx));
            }
            if !vis[idx] {
                continue;
            }
            if let Some(obj) = cell {
                match obj.kind {
                    ObjectKind::Wall => continue,
                    ObjectKind::Door if obj.state != DoorState::Open => continue,
                    ObjectKind::Door => {}
                    _ if !ignore_blockers => continue,
                    _ => {}
                }
            }
            // BabyAI's order: ahead, then (dj, di) and (−dj, −di), then back.
            for (k, l) in [(di, dj), (dj, di), (-dj, -di), (-di, -dj)] {
                frontier.queue.push_back((i + k, j + l, k, l, idx as i32));
            }
        }
        Ok(None)
    }

    /// The cells from a search's start to `idx`, start included, following `prev`.
    fn walk_back(&self, prev: &[i32], idx: usize, out: &mut Vec<Pos>) {
        let mut at = idx as i32;
        while at >= 0 {
            out.push(self.pos_of(at as usize));
            at = prev[at as usize];
        }
    }

    /// `_shortest_path`: a path to a cell `accept` takes, avoiding blockers; with
    /// `try_with_blockers`, when none exists, a path that goes through them as late as
    /// possible (a second search from every cell the first one entered).
    pub fn shortest_path(
        &mut self,
        world: &World,
        accept: &mut dyn FnMut(Pos, Cell) -> bool,
        try_with_blockers: bool,
    ) -> Result<ShortPath, GiveUp> {
        let (dx, dy) = crate::env::DIR_TO_VEC[usize::from(world.agent_dir & 3)];
        let (ax, ay) = world.agent_pos;
        let dims = (self.vis.as_slice(), self.width, self.height);
        let found = Self::bfs(
            &mut self.first,
            dims,
            &world.grid,
            &mut std::iter::once((ax, ay, dx, dy)),
            accept,
            false,
        )?;
        let mut out = ShortPath::default();
        let mut back = Vec::new();
        if let Some(idx) = found {
            self.walk_back(&self.first.prev, idx, &mut back);
            out.finish = Some(self.pos_of(idx));
        } else if try_with_blockers {
            out.with_blockers = true;
            let height = self.height;
            let mut starts = self.first.order.iter().map(|&k| {
                let k = k as i32;
                (k / height, k % height, 1, 0)
            });
            let found = Self::bfs(
                &mut self.second,
                dims,
                &world.grid,
                &mut starts,
                accept,
                true,
            )?;
            if let Some(idx) = found {
                self.walk_back(&self.second.prev, idx, &mut back);
                // `back` ends at a cell the first search entered: go on to the agent.
                if let Some(&root) = back.last()
                    && let Some(r) = self.index(root)
                {
                    back.pop();
                    self.walk_back(&self.first.prev, r, &mut back);
                }
                out.finish = Some(self.pos_of(idx));
            }
        }
        if out.finish.is_some() {
            back.reverse();
            back.remove(0);
            out.path = Some(back);
        }
        Ok(out)
    }

    /// `_find_obj_pos`: of the objects `obj_set` matched (paired by index with `obj_poss`, as
    /// Python pairs them even after a pickup shortened one list), the closest seen one that
    /// is not carried, with a path through blockers costing 4 (7 when carrying) more. With
    /// `adjacent` (PutNext), standing right next to it counts as 3.
    pub fn find_obj_pos(
        &mut self,
        world: &World,
        desc_kind: Option<ObjectKind>,
        obj_set: &[ObjectId],
        obj_poss: &[Pos],
        adjacent: bool,
    ) -> Result<(Option<ObjectId>, Option<Pos>), GiveUp> {
        if obj_set.is_empty() {
            return Err(GiveUp::Broken("a description matched no object".into()));
        }
        let carrying = world.carrying.map(|c| c.id);
        let mut best = 999usize;
        let (mut best_obj, mut best_pos) = (None, None);
        for (i, &obj) in obj_set.iter().enumerate() {
            // Only a description without a type (or of walls) can have matched a wall.
            let may_be_wall = matches!(desc_kind, None | Some(ObjectKind::Wall));
            if (may_be_wall && kind_of(world, obj) == Some(ObjectKind::Wall))
                || Some(obj) == carrying
            {
                continue;
            }
            // Python's IndexError, caught: a tracked object left the grid.
            let Some(&obj_pos) = obj_poss.get(i) else {
                continue;
            };
            if !self.seen(obj_pos) {
                continue;
            }
            let sp = self.shortest_path(world, &mut |p, _| p == obj_pos, true)?;
            let Some(path) = sp.path else {
                return Err(GiveUp::Broken("no path to a seen object".into()));
            };
            let mut d = path.len();
            if sp.with_blockers {
                d += if world.carrying.is_some() { 7 } else { 4 };
            }
            if d == 0 {
                d = if adjacent { 3 } else { 2 };
            }
            if adjacent && d == 1 {
                d = 3;
            }
            if d < best {
                best = d;
                best_pos = Some(obj_pos);
                best_obj = Some(obj);
            }
        }
        Ok((best_obj, best_pos))
    }

    /// `_find_drop_pos`: the closest seen empty cell (not the agent's, not `except`) where an
    /// object would not cut its neighbourhood in two, then any empty one, then both again
    /// through blockers.
    pub fn find_drop_pos(
        &mut self,
        world: &World,
        except: Option<Pos>,
    ) -> Result<Option<Pos>, GiveUp> {
        let agent = world.agent_pos;
        let (width, height, vis) = (self.width, self.height, self.vis.clone());
        let seen = |(x, y): Pos| {
            x >= 0 && y >= 0 && x < width && y < height && vis[(x * height + y) as usize]
        };
        let grid = &world.grid;
        let mut unblock = |pos: Pos, _cell: Cell| {
            if pos == agent || except == Some(pos) || !seen(pos) || grid.get(pos).is_some() {
                return false;
            }
            let mut class = [0u8; 8];
            for (c, (k, l)) in class.iter_mut().zip([
                (-1, -1),
                (0, -1),
                (1, -1),
                (1, 0),
                (1, 1),
                (0, 1),
                (-1, 1),
                (-1, 0),
            ]) {
                let nb = (pos.0 + k, pos.1 + l);
                let cell = grid.get(nb);
                let is_seen = seen(nb);
                *c = if is_seen && cell.is_some_and(|o| o.kind == ObjectKind::Wall) {
                    1
                } else if is_seen
                    && (cell
                        .is_none_or(|o| o.kind == ObjectKind::Door && o.state == DoorState::Open)
                        || nb == agent)
                    && Some(nb) != except
                {
                    0
                } else {
                    2
                };
            }
            let changes = (0..8)
                .filter(|&i| (class[(i + 1) % 8] != 0) != (class[i] != 0))
                .count();
            let cut_off =
                (0..8).any(|i| class[i] == 2 && class[(i + 7) % 8] != 0 && class[(i + 1) % 8] != 0);
            !cut_off && changes <= 2
        };
        let mut empty = |pos: Pos, _cell: Cell| {
            pos != agent && except != Some(pos) && seen(pos) && grid.get(pos).is_none()
        };
        for (which, blockers) in [(0, false), (1, false), (0, true), (1, true)] {
            let accept: &mut dyn FnMut(Pos, Cell) -> bool =
                if which == 0 { &mut unblock } else { &mut empty };
            if let Some(p) = self.shortest_path(world, accept, blockers)?.finish {
                return Ok(Some(p));
            }
        }
        Ok(None)
    }
}

/// What kind of object `id` is, on the grid or in the agent's hands.
pub(crate) fn kind_of(world: &World, id: ObjectId) -> Option<ObjectKind> {
    if let Some(c) = world.carrying.filter(|c| c.id == id) {
        return Some(c.kind);
    }
    world
        .grid
        .find_id(id)
        .and_then(|p| world.grid.get(p))
        .map(|o| o.kind)
}

/// `_closest_wall_or_door_given_dir`: how many cells from `pos` along `dir` the first wall or
/// door lies, counting only cells in the agent's view (past its edge, the last one in it).
pub(crate) fn closest_wall_or_door(world: &World, pos: Pos, dir: Pos) -> i32 {
    let mut distance = 1;
    loop {
        let p = (pos.0 + distance * dir.0, pos.1 + distance * dir.1);
        if view_from_world(world.agent_pos, world.agent_dir, p).is_none() {
            return distance - 1;
        }
        if world
            .grid
            .get(p)
            .is_some_and(|o| matches!(o.kind, ObjectKind::Door | ObjectKind::Wall))
        {
            return distance;
        }
        distance += 1;
    }
}
