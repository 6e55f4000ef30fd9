//! MiniGrid's own environments (the `MiniGrid-*` ids of minigrid 3.2.0), generated bit for
//! bit: the same id (or class with its keyword arguments) and seed give the same grid, agent
//! pose, box contents and mission as `gym.make(id).reset(seed=seed)`, and every step the same
//! observation, reward, `terminated` and `truncated`.
//!
//! They share BabyAI's machinery — numpy's stream ([`crate::env::rng`]), `place_obj` and
//! RoomGrid ([`crate::env::babyai::roomgrid`]), the objects and `MiniGridEnv.step`
//! ([`crate::env::World`]) — and add each environment's own step rules ([`rules`]). One file
//! per family, as minigrid splits them: [`single`] (one room: Empty, DoorKey, FourRooms,
//! LavaGap, DistShift, Crossing, Dynamic-Obstacles), [`objects`] (Fetch, GoToObject,
//! GoToDoor, PutNear), [`layouts`] (MultiRoom, LockedRoom, Playground, RedBlueDoors, Memory)
//! and [`rooms`] (the RoomGrid ones: KeyCorridor, Unlock, UnlockPickup, BlockedUnlockPickup,
//! ObstructedMaze). [`registry`] lists the 76 ids and parses the class spelling.

pub mod ids;
pub mod layouts;
pub mod objects;
pub mod registry;
pub mod rooms;
pub mod rules;
pub mod single;
pub mod spelling;
pub mod words;

pub use registry::{Class, WFC_IDS, parse_class};
pub use rules::Rules;
pub use spelling::looks_like_class;

use super::babyai::roomgrid::{Gen, Retry};
use super::error::EnvError;
use super::grid::{Grid, Pos, Rooms};
use super::instr::Instr;
use super::mission::{Instruction, ObjDesc, TaskKind};
use super::object::{Color, DoorState, ObjectKind, WorldObj};
use super::rng::NumpyRng;
use super::world::World;

/// `place_obj`'s `max_tries=math.inf`: minigrid draws until a cell is free. A grid with no
/// free cell would loop forever there; here it stops with an error after this many draws.
pub const INF_TRIES: u32 = 1_000_000;

/// What one environment's `_gen_grid` leaves beside the grid: the mission, the rules its
/// `step` adds, and an instruction describing what the mission names (for the analyses).
pub struct Made {
    /// `self.mission`.
    pub mission: String,
    /// The environment's own step rules.
    pub rules: Rules,
    /// What the mission names, as a BabyAI instruction (GoTo the goal, Pickup the ball, …).
    pub instr: Instr,
}

/// A description with no location.
fn desc(kind: ObjectKind, color: Option<Color>) -> ObjDesc {
    ObjDesc {
        kind: Some(kind),
        color,
        loc: None,
    }
}

/// The instruction "go to the green goal", for missions that end at a goal.
fn to_goal() -> Instr {
    Instruction::new(TaskKind::GoTo, desc(ObjectKind::Goal, Some(Color::Green))).into()
}

/// A one-clause instruction on `kind` of `color`.
fn clause(task: TaskKind, kind: ObjectKind, color: Color) -> Instr {
    Instruction::new(task, desc(kind, Some(color))).into()
}

/// `Grid(width, height)` and a generator drawing from `rng`, the agent at `(-1, -1)` as
/// `reset` leaves it before `_gen_grid`.
fn blank(width: i32, height: i32, rng: NumpyRng) -> Gen {
    let mut g = Gen::with_rng(Rooms::single(width as usize, height as usize), rng);
    g.grid = Grid::new(width as usize, height as usize);
    g
}

impl Gen {
    /// `Grid.set(x, y, obj)` of a new object.
    pub(crate) fn put(&mut self, pos: Pos, kind: ObjectKind, color: Color) -> WorldObj {
        let o = self.obj(kind, color);
        self.grid.set(pos, Some(o));
        o
    }

    /// `Grid.set(x, y, Door(color, is_locked=locked))`: closed, or locked.
    pub(crate) fn put_door(&mut self, pos: Pos, color: Color, locked: bool) -> WorldObj {
        let mut d = self.obj(ObjectKind::Door, color);
        d.state = if locked {
            DoorState::Locked
        } else {
            DoorState::Closed
        };
        self.grid.set(pos, Some(d));
        d
    }

    /// `Grid.horz_wall(x, y, length)` of `kind` (Wall or Lava in their own colours).
    pub(crate) fn horz_wall(&mut self, x: i32, y: i32, length: Option<i32>, kind: ObjectKind) {
        let length = length.unwrap_or(self.grid.width() as i32 - x);
        for i in 0..length {
            self.put((x + i, y), kind, default_color(kind));
        }
    }

    /// `Grid.vert_wall(x, y, length)` of `kind`.
    pub(crate) fn vert_wall(&mut self, x: i32, y: i32, length: Option<i32>, kind: ObjectKind) {
        let length = length.unwrap_or(self.grid.height() as i32 - y);
        for j in 0..length {
            self.put((x, y + j), kind, default_color(kind));
        }
    }

    /// `Grid.wall_rect(x, y, w, h)`: the rectangle's border.
    pub(crate) fn wall_rect(&mut self, x: i32, y: i32, w: i32, h: i32) {
        self.horz_wall(x, y, Some(w), ObjectKind::Wall);
        self.horz_wall(x, y + h - 1, Some(w), ObjectKind::Wall);
        self.vert_wall(x, y, Some(h), ObjectKind::Wall);
        self.vert_wall(x + w - 1, y, Some(h), ObjectKind::Wall);
    }

    /// `MiniGridEnv.place_agent(top, size)`: a free cell of the rectangle (the whole grid by
    /// default), then a direction.
    pub(crate) fn place_agent_in(
        &mut self,
        top: Option<Pos>,
        size: Option<(i32, i32)>,
    ) -> Result<Pos, Retry> {
        self.agent_pos = (-1, -1);
        let size = size.unwrap_or((self.grid.width() as i32, self.grid.height() as i32));
        let pos = self.place_obj(None, top.unwrap_or((0, 0)), size, false, INF_TRIES)?;
        self.agent_pos = pos;
        self.agent_dir = self.rng.below(0, 4) as u8;
        Ok(pos)
    }

    /// `MiniGridEnv.place_obj(obj)` anywhere in the grid, no rejection.
    pub(crate) fn place_anywhere(&mut self, obj: WorldObj) -> Result<Pos, Retry> {
        let size = (self.grid.width() as i32, self.grid.height() as i32);
        self.place_obj(Some(obj), (0, 0), size, false, INF_TRIES)
    }
}

/// The colour minigrid gives an object made without one (`Wall()`, `Lava()`, `Goal()`,
/// `Ball()`, `Key()`).
pub fn default_color(kind: ObjectKind) -> Color {
    match kind {
        ObjectKind::Wall => Color::Grey,
        ObjectKind::Lava => Color::Red,
        ObjectKind::Goal => Color::Green,
        _ => Color::Blue,
    }
}

/// Generates `class` from `rng` as `reset` does, with `max_steps` its horizon; `rng` is left
/// where generation left numpy's stream (a `reset()` without a seed continues from there).
/// `seed` only names the stream in errors.
pub fn generate(
    class: &Class,
    rng: &mut NumpyRng,
    max_steps: u32,
    seed: u64,
) -> Result<World, EnvError> {
    let (mut g, made) = class.gen_grid(rng.clone()).map_err(|why| match why {
        Retry::Endless(why) | Retry::Reject(why) | Retry::Recursion(why) => {
            EnvError::GenerationHangs {
                level: class.spelling(),
                seed,
                why,
            }
        }
    })?;
    rng.clone_from(&g.rng);
    let see_through = class.see_through_walls();
    let rooms = g.rooms;
    let box_contents = std::mem::take(&mut g.box_contents);
    // Dynamic-Obstacles' rules took the stream where its `_gen_grid` ended (the last draws).
    let rules = made.rules;
    let mut world = World::minigrid(
        std::mem::replace(&mut g.grid, Grid::empty()),
        rooms,
        (g.agent_pos, g.agent_dir),
        made.instr,
        made.mission,
        max_steps,
        g.next_id,
        (rules, see_through),
    )?;
    world.box_contents = box_contents;
    Ok(world)
}

impl Class {
    /// Whether the class is a RoomGrid (its grid starts as `RoomGrid._gen_grid` leaves it).
    pub const fn is_room_grid(&self) -> bool {
        matches!(
            self,
            Self::KeyCorridor { .. }
                | Self::Unlock
                | Self::UnlockPickup
                | Self::BlockedUnlockPickup
                | Self::ObstructedMaze1 { .. }
                | Self::ObstructedMazeFull { .. }
        )
    }

    /// `reset`'s `_gen_grid`, drawing from `rng`: the generator it leaves and what it made.
    pub(crate) fn gen_grid(&self, rng: NumpyRng) -> Result<(Gen, Made), Retry> {
        let mut g = if self.is_room_grid() {
            let mut g = Gen::with_rng(self.rooms(), rng);
            g.gen_grid();
            g
        } else {
            let (w, h) = self.grid_size();
            blank(w, h, rng)
        };
        let made = match *self {
            Self::Empty { agent_start, .. } => single::empty(&mut g, agent_start),
            Self::DoorKey { .. } => single::door_key(&mut g),
            Self::FourRooms {
                agent_pos,
                goal_pos,
            } => single::four_rooms(&mut g, agent_pos, goal_pos),
            Self::LavaGap { lava, .. } => single::lava_gap(&mut g, lava),
            Self::DistShift {
                agent_start,
                strip2_row,
                ..
            } => single::dist_shift(&mut g, agent_start, strip2_row),
            Self::Crossing {
                num_crossings,
                lava,
                ..
            } => single::crossing(&mut g, num_crossings, lava),
            Self::DynamicObstacles {
                agent_start,
                n_obstacles,
                ..
            } => single::dynamic_obstacles(&mut g, agent_start, n_obstacles),
            Self::Fetch { num_objs, .. } => objects::fetch(&mut g, num_objs),
            Self::GoToDoor { .. } => objects::go_to_door(&mut g),
            Self::GoToObject { num_objs, .. } => objects::go_to_object(&mut g, num_objs),
            Self::PutNear { num_objs, .. } => objects::put_near(&mut g, num_objs),
            Self::RedBlueDoors { .. } => layouts::red_blue_doors(&mut g),
            Self::LockedRoom { .. } => layouts::locked_room(&mut g),
            Self::Memory { random_length, .. } => layouts::memory(&mut g, random_length),
            Self::MultiRoom {
                min_rooms,
                max_rooms,
                max_room_size,
                ..
            } => layouts::multi_room(&mut g, min_rooms, max_rooms, max_room_size),
            Self::Playground => layouts::playground(&mut g),
            Self::KeyCorridor { obj, .. } => rooms::key_corridor(&mut g, obj),
            Self::Unlock => rooms::unlock(&mut g),
            Self::UnlockPickup => rooms::unlock_pickup(&mut g, false),
            Self::BlockedUnlockPickup => rooms::unlock_pickup(&mut g, true),
            Self::ObstructedMaze1 {
                key_in_box,
                blocked,
            } => rooms::obstructed_1(&mut g, key_in_box, blocked),
            Self::ObstructedMazeFull {
                v1,
                agent_room,
                key_in_box,
                blocked,
                num_quarters,
                ..
            } => {
                rooms::obstructed_full(&mut g, v1, agent_room, (key_in_box, blocked), num_quarters)
            }
        }?;
        // `reset` asserts the agent stands on an empty or overlappable cell.
        if g.grid.get(g.agent_pos).is_some_and(|o| !o.can_overlap()) {
            return Err(Retry::Endless("the agent was placed on an object"));
        }
        Ok((g, made))
    }
}
