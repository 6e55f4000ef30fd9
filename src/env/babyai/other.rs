//! The levels of `minigrid/envs/babyai/other.py`.

use super::roomgrid::{COLOR_NAMES, Gen, Retry};
use super::{Generated, desc};
use crate::env::instr::Instr;
use crate::env::mission::{Instruction, TaskKind};
use crate::env::object::ObjectKind;

/// `ActionObjDoor`: go to / pick up an object, or go to / open a door, of the middle room.
pub fn action_obj_door(g: &mut Gen) -> Result<Generated, Retry> {
    let mut objs = g.add_distractors(Some(1), Some(1), 5, true)?;
    for _ in 0..4 {
        let (d, _) = g.add_door(1, 1, None, None, Some(false));
        objs.push(d);
    }
    g.place_agent(Some(1), Some(1))?;
    let obj = g.rand_elem(&objs);
    let d = desc(Some(obj.kind), Some(obj.color));
    let task = if obj.kind == ObjectKind::Door {
        if g.rand_bool() {
            TaskKind::GoTo
        } else {
            TaskKind::Open
        }
    } else if g.rand_bool() {
        TaskKind::GoTo
    } else {
        TaskKind::Pickup
    };
    Ok(Instr::from(Instruction::new(task, d)).into())
}

/// `FindObjS5` (and S6, S7): an object in a random room; the rows and columns of its room
/// are drawn swapped, as in Python (the grid is square).
pub fn find_obj(g: &mut Gen) -> Result<Generated, Retry> {
    let i = g.rand_int(0, g.rooms.num_rows);
    let j = g.rand_int(0, g.rooms.num_cols);
    let (obj, _) = g.add_object(i, j, None, None)?;
    g.place_agent(Some(1), Some(1))?;
    g.connect_all(&COLOR_NAMES)?;
    Ok(Instr::from(Instruction::new(
        TaskKind::Pickup,
        desc(Some(obj.kind), None),
    ))
    .into())
}

/// `KeyCorridor`: a corridor of rooms, the object behind a locked door, its key elsewhere.
pub fn key_corridor(g: &mut Gen, obj_type: ObjectKind) -> Result<Generated, Retry> {
    let rows = g.rooms.num_rows;
    for j in 1..rows {
        g.remove_wall(1, j, 3);
    }
    let room_idx = g.rand_int(0, rows);
    let (door, _) = g.add_door(2, room_idx, Some(2), None, Some(true));
    let (obj, _) = g.add_object(2, room_idx, Some(obj_type), None)?;
    let key_row = g.rand_int(0, rows);
    g.add_object(0, key_row, Some(ObjectKind::Key), Some(door.color))?;
    g.place_agent(Some(1), Some(rows / 2))?;
    g.connect_all(&COLOR_NAMES)?;
    Ok(Instr::from(Instruction::new(
        TaskKind::Pickup,
        desc(Some(obj.kind), None),
    ))
    .into())
}

/// `OneRoomS8` (and S12, S16, S20): pick up the ball.
pub fn one_room(g: &mut Gen) -> Result<Generated, Retry> {
    let (obj, _) = g.add_object(0, 0, Some(ObjectKind::Ball), None)?;
    g.place_agent(None, None)?;
    Ok(Instr::from(Instruction::new(
        TaskKind::Pickup,
        desc(Some(obj.kind), None),
    ))
    .into())
}
