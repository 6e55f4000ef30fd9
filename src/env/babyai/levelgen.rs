//! `LevelGen` (`minigrid/envs/babyai/core/levelgen.py`): the random-instruction levels
//! (GoToSeq, PickupLoc, Synth*, MiniBossLevel, BossLevel*).

use super::Generated;
use super::open::LOC_NAMES;
use super::roomgrid::{COLOR_NAMES, Gen, Retry};
use crate::env::grid::Pos;
use crate::env::instr::{Instr, SeqKind};
use crate::env::mission::{Instruction, ObjDesc, TaskKind};
use crate::env::object::{Color, ObjectKind, WorldObj};

/// `OBJ_TYPES`, in BabyAI's order (not the distractors' order).
const OBJ_TYPES: [ObjectKind; 4] = [
    ObjectKind::Box,
    ObjectKind::Ball,
    ObjectKind::Key,
    ObjectKind::Door,
];
/// `OBJ_TYPES_NOT_DOOR`.
const OBJ_TYPES_NOT_DOOR: [ObjectKind; 3] = [ObjectKind::Box, ObjectKind::Ball, ObjectKind::Key];

/// `instr_kinds`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InstrKind {
    /// One clause.
    Action,
    /// `And` of two clauses.
    And,
    /// `Before` / `After` of two clauses or Ands.
    Seq,
}

/// LevelGen's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// `num_dists`.
    pub num_dists: usize,
    /// `locked_room_prob`.
    pub locked_room_prob: f64,
    /// `locations`.
    pub locations: bool,
    /// `unblocking`.
    pub unblocking: bool,
    /// `implicit_unlock`.
    pub implicit_unlock: bool,
    /// `action_kinds`.
    pub action_kinds: &'static [TaskKind],
    /// `instr_kinds`.
    pub instr_kinds: &'static [InstrKind],
}

/// Every action kind, in LevelGen's order.
pub const ALL_ACTIONS: &[TaskKind] = &[
    TaskKind::GoTo,
    TaskKind::Pickup,
    TaskKind::Open,
    TaskKind::PutNext,
];
/// Every instruction kind.
pub const ALL_INSTRS: &[InstrKind] = &[InstrKind::Action, InstrKind::And, InstrKind::Seq];

impl Params {
    /// `LevelGen`'s defaults (BossLevel's).
    pub const BOSS: Self = Self {
        num_dists: 18,
        locked_room_prob: 0.5,
        locations: true,
        unblocking: true,
        implicit_unlock: true,
        action_kinds: ALL_ACTIONS,
        instr_kinds: ALL_INSTRS,
    };
}

/// `LevelGen.gen_mission`.
pub fn gen_mission(g: &mut Gen, p: &Params) -> Result<Generated, Retry> {
    let mut locked_room = None;
    // The roll is drawn even when the probability is 0.
    if g.rng.uniform(0.0, 1.0) < p.locked_room_prob {
        locked_room = Some(add_locked_room(g)?);
    }
    g.connect_all(&COLOR_NAMES)?;
    g.add_distractors(None, None, p.num_dists, false)?;
    g.place_agent_outside(locked_room)?;
    if !p.unblocking {
        g.check_objs_reachable()?;
    }
    // The grid is final from here on: its objects are gathered once for every description.
    let objects = g.grid.objects_but_walls();
    let instr = rand_instr(g, p, &objects, locked_room, p.action_kinds, p.instr_kinds)?;
    let mut out = Generated::from(instr);
    out.unblocking = p.unblocking;
    out.objects = Some(objects);
    Ok(out)
}

/// `add_locked_room`: a locked door on a random room, its key in another room.
fn add_locked_room(g: &mut Gen) -> Result<usize, Retry> {
    let (cols, rows) = (g.rooms.num_cols, g.rooms.num_rows);
    let (room, color) = loop {
        let i = g.rand_int(0, cols);
        let j = g.rand_int(0, rows);
        let k = g.rng.below(0, 4);
        let r = g.room_index(i, j);
        if g.room_list[r].neighbors[k].is_none() {
            continue;
        }
        let (door, _) = g.add_door(i, j, Some(k), None, Some(true));
        break (r, door.color);
    };
    loop {
        let i = g.rand_int(0, cols);
        let j = g.rand_int(0, rows);
        if g.room_index(i, j) == room {
            continue;
        }
        g.add_object(i, j, Some(ObjectKind::Key), Some(color))?;
        break;
    }
    Ok(room)
}

/// `rand_obj(types)`: a description that matches something (outside the locked room when
/// unlocking must be explicit).
fn rand_obj(
    g: &mut Gen,
    p: &Params,
    objects: &[(Pos, WorldObj)],
    locked_room: Option<usize>,
    types: &[ObjectKind],
) -> Result<ObjDesc, Retry> {
    let mut colors: [Option<Color>; 7] = [None; 7];
    for (slot, c) in colors[1..].iter_mut().zip(COLOR_NAMES) {
        *slot = Some(c);
    }
    // A description must match an object outside the locked room when unlocking must be
    // explicit.
    let locked = locked_room.filter(|_| !p.implicit_unlock).map(|room| {
        let cols = g.rooms.num_cols;
        ((room as i32) % cols, (room as i32) / cols)
    });
    let mut tries = 0;
    loop {
        if tries > 100 {
            return Err(Retry::Recursion("failed to find suitable object"));
        }
        tries += 1;
        let color = g.rand_elem(&colors);
        let kind = g.rand_elem(types);
        let mut loc = None;
        if p.locations && g.rand_bool() {
            loc = Some(g.rand_elem(&LOC_NAMES));
        }
        let desc = ObjDesc {
            kind: Some(kind),
            color,
            loc,
        };
        let (rooms, pos, dir) = (g.rooms, g.agent_pos, g.agent_dir);
        let outside = |at: Pos| locked.is_none_or(|room| !rooms.pos_inside(room, at));
        if !desc.any_matching_among(objects, &g.grid, rooms, pos, dir, outside) {
            continue;
        }
        return Ok(desc);
    }
}

/// `rand_instr(action_kinds, instr_kinds)`.
fn rand_instr(
    g: &mut Gen,
    p: &Params,
    objects: &[(Pos, WorldObj)],
    locked_room: Option<usize>,
    actions: &[TaskKind],
    kinds: &[InstrKind],
) -> Result<Instr, Retry> {
    match g.rand_elem(kinds) {
        InstrKind::Action => {
            let action = g.rand_elem(actions);
            Ok(match action {
                TaskKind::GoTo => {
                    Instruction::new(action, rand_obj(g, p, objects, locked_room, &OBJ_TYPES)?)
                }
                TaskKind::Pickup => Instruction::new(
                    action,
                    rand_obj(g, p, objects, locked_room, &OBJ_TYPES_NOT_DOOR)?,
                ),
                TaskKind::Open => Instruction::new(
                    action,
                    rand_obj(g, p, objects, locked_room, &[ObjectKind::Door])?,
                ),
                TaskKind::PutNext => {
                    let moved = rand_obj(g, p, objects, locked_room, &OBJ_TYPES_NOT_DOOR)?;
                    let fixed = rand_obj(g, p, objects, locked_room, &OBJ_TYPES)?;
                    Instruction::put_next(moved, fixed)
                }
            }
            .into())
        }
        InstrKind::And => {
            let a = rand_instr(g, p, objects, locked_room, actions, &[InstrKind::Action])?;
            let b = rand_instr(g, p, objects, locked_room, actions, &[InstrKind::Action])?;
            Ok(Instr::seq(SeqKind::And, a, b))
        }
        InstrKind::Seq => {
            let parts = [InstrKind::Action, InstrKind::And];
            let a = rand_instr(g, p, objects, locked_room, actions, &parts)?;
            let b = rand_instr(g, p, objects, locked_room, actions, &parts)?;
            let kind = g.rand_elem(&[SeqKind::Before, SeqKind::After]);
            Ok(Instr::seq(kind, a, b))
        }
    }
}
