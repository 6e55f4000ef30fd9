//! The Unlock family (`minigrid/envs/babyai/unlock.py`).

use super::roomgrid::{COLOR_NAMES, Gen, Retry};
use super::{Generated, desc};
use crate::env::instr::Instr;
use crate::env::mission::{Instruction, TaskKind};
use crate::env::object::{Color, ObjectKind, WorldObj};

fn open_door(color: Option<Color>) -> Instr {
    Instruction::new(TaskKind::Open, desc(Some(ObjectKind::Door), color)).into()
}

fn pickup(kind: ObjectKind, color: Option<Color>) -> Instr {
    Instruction::new(TaskKind::Pickup, desc(Some(kind), color)).into()
}

/// The start of `Unlock` and `GoToImpUnlock`: a locked door on a random room and its key in a
/// random room. Python's `ik is id and jk is jd` compares numpy integers by identity, which
/// never holds, so the key is never redrawn: it may land in the locked room. Returns the door
/// and the locked room `(i, j)`.
pub fn locked_door_and_key(g: &mut Gen) -> Result<(WorldObj, (i32, i32)), Retry> {
    let (cols, rows) = (g.rooms.num_cols, g.rooms.num_rows);
    let id = g.rand_int(0, cols);
    let jd = g.rand_int(0, rows);
    let (door, _) = g.add_door(id, jd, None, None, Some(true));
    let ik = g.rand_int(0, cols);
    let jk = g.rand_int(0, rows);
    g.add_object(ik, jk, Some(ObjectKind::Key), Some(door.color))?;
    Ok((door, (id, jd)))
}

/// `Unlock`: open a locked door of the maze. As in `GoToImpUnlock`, Python's identity test
/// of numpy integers never holds: the key may be in the locked room, every room gets three
/// distractors.
pub fn unlock(g: &mut Gen) -> Result<Generated, Retry> {
    let (cols, rows) = (g.rooms.num_cols, g.rooms.num_rows);
    let (door, locked) = locked_door_and_key(g)?;
    if g.rand_bool() {
        let colors: Vec<Color> = COLOR_NAMES
            .into_iter()
            .filter(|c| *c != door.color)
            .collect();
        g.connect_all(&colors)?;
    } else {
        g.connect_all(&COLOR_NAMES)?;
    }
    for i in 0..cols {
        for j in 0..rows {
            g.add_distractors(Some(i), Some(j), 3, false)?;
        }
    }
    g.place_agent_outside(Some(g.room_index(locked.0, locked.1)))?;
    g.check_objs_reachable()?;
    Ok(open_door(Some(door.color)).into())
}

/// `UnlockLocal`: a locked door and its key in the middle room.
pub fn local(g: &mut Gen, distractors: bool) -> Result<Generated, Retry> {
    let (door, _) = g.add_door(1, 1, None, None, Some(true));
    g.add_object(1, 1, Some(ObjectKind::Key), Some(door.color))?;
    if distractors {
        g.add_distractors(Some(1), Some(1), 3, true)?;
    }
    g.place_agent(Some(1), Some(1))?;
    Ok(open_door(None).into())
}

/// `KeyInBox`: the key is inside a box.
pub fn key_in_box(g: &mut Gen) -> Result<Generated, Retry> {
    let (door, _) = g.add_door(1, 1, None, None, Some(true));
    let key = g.obj(ObjectKind::Key, door.color);
    let box_color = g.rand_color();
    let bx = g.obj(ObjectKind::Box, box_color);
    g.box_contents.push((bx.id, key));
    g.place_in_room(1, 1, bx)?;
    g.place_agent(Some(1), Some(1))?;
    Ok(open_door(None).into())
}

/// `UnlockPickup`: pick up the box behind a locked door.
pub fn unlock_pickup(g: &mut Gen, distractors: bool) -> Result<Generated, Retry> {
    let (obj, _) = g.add_object(1, 0, Some(ObjectKind::Box), None)?;
    let (door, _) = g.add_door(0, 0, Some(0), None, Some(true));
    g.add_object(0, 0, Some(ObjectKind::Key), Some(door.color))?;
    if distractors {
        g.add_distractors(None, None, 4, true)?;
    }
    g.place_agent(Some(0), Some(0))?;
    Ok(pickup(obj.kind, Some(obj.color)).into())
}

/// `BlockedUnlockPickup`: as `UnlockPickup`, with a ball in front of the door.
pub fn blocked_unlock_pickup(g: &mut Gen) -> Result<Generated, Retry> {
    let (obj, _) = g.add_object(1, 0, Some(ObjectKind::Box), None)?;
    let (door, pos) = g.add_door(0, 0, Some(0), None, Some(true));
    let color = g.rand_color();
    let ball = g.obj(ObjectKind::Ball, color);
    g.grid.set((pos.0 - 1, pos.1), Some(ball));
    g.add_object(0, 0, Some(ObjectKind::Key), Some(door.color))?;
    g.place_agent(Some(0), Some(0))?;
    Ok(pickup(obj.kind, None).into())
}

/// `UnlockToUnlock`: a key behind one locked door opens the next.
pub fn unlock_to_unlock(g: &mut Gen) -> Result<Generated, Retry> {
    let colors = g.rand_subset(&COLOR_NAMES, 2);
    g.add_door(0, 0, Some(0), Some(colors[0]), Some(true));
    g.add_object(2, 0, Some(ObjectKind::Key), Some(colors[0]))?;
    g.add_door(1, 0, Some(0), Some(colors[1]), Some(true));
    g.add_object(1, 0, Some(ObjectKind::Key), Some(colors[1]))?;
    let (obj, _) = g.add_object(0, 0, Some(ObjectKind::Ball), None)?;
    g.place_agent(Some(1), Some(0))?;
    Ok(pickup(obj.kind, None).into())
}
