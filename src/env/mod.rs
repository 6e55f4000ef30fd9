//! The world: a faithful port of MiniGrid 3.2.0 / BabyAI: every registered BabyAI level
//! ([`babyai`]) and MiniGrid environment ([`minigrid`]), generated bit for bit from numpy's
//! stream ([`rng`]), and the paper's levels as BabyAI's GoToLocal. Pure: no I/O, no ML, nothing else of the crate.
//!
//! Conventions (MiniGrid's): arrays are x-major (`grid[x][y]`, `image[vx][vy]`), `y` grows
//! downward, directions are 0 = right, 1 = down, 2 = left, 3 = up. The agent sees a 7×7 view
//! in which it stands at `(3, 6)` facing up (see [`view`]).

pub mod babyai;
pub mod edit;
pub mod error;
pub mod grid;
pub mod gym;
pub mod instr;
pub mod level;
pub mod level_id;
pub mod minigrid;
pub mod mission;
pub mod object;
pub mod rng;
pub mod roles;
pub mod seeds;
pub mod snapshot;
pub mod targets;
pub mod tree;
pub mod view;
pub mod vocab;
pub mod world;

pub use error::EnvError;
pub use grid::{DIR_TO_VEC, Grid, Pos, Rooms};
pub use instr::{Instr, SeqKind, Status, parse_mission};
pub use level::{LevelConfig, LevelId, TaskSet};
pub use mission::{Instruction, Loc, ObjDesc, TaskKind};
pub use object::{Cell, Color, DoorState, ObjectId, ObjectKind, WorldObj};
pub use snapshot::{Mismatch, Snapshot, verify_dump};
pub use view::{AGENT_IN_VIEW, Observation, VIEW_SIZE, ViewCell, view_from_world, world_from_view};
pub use world::{Action, StepOutcome, World};
