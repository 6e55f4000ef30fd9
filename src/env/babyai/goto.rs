//! The GoTo family (`minigrid/envs/babyai/goto.py`).

use super::roomgrid::{COLOR_NAMES, Gen, Retry};
use super::{Generated, desc, door_list};
use crate::env::instr::Instr;
use crate::env::level::TaskSet;
use crate::env::mission::{Instruction, TaskKind};
use crate::env::object::{Color, ObjectKind};

fn goto(kind: ObjectKind, color: Color) -> Instr {
    Instruction::new(TaskKind::GoTo, desc(Some(kind), Some(color))).into()
}

/// `GoToRedBallGrey`: a red ball among grey distractors (recoloured after placement).
pub fn red_ball_grey(g: &mut Gen, num_dists: usize) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    let (obj, _) = g.add_object(0, 0, Some(ObjectKind::Ball), Some(Color::Red))?;
    let dists = g.add_distractors(None, None, num_dists, false)?;
    for d in dists {
        g.recolor(d.id, Color::Grey);
    }
    g.check_objs_reachable()?;
    Ok(goto(obj.kind, obj.color).into())
}

/// `GoToRedBall` (and `GoToRedBallNoDists` with no distractors).
pub fn red_ball(g: &mut Gen, num_dists: usize) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    let (obj, _) = g.add_object(0, 0, Some(ObjectKind::Ball), Some(Color::Red))?;
    g.add_distractors(None, None, num_dists, false)?;
    g.check_objs_reachable()?;
    Ok(goto(obj.kind, obj.color).into())
}

/// `GoToObj`: one object, no reachability check.
pub fn obj(g: &mut Gen) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    let objs = g.add_distractors(None, None, 1, true)?;
    let obj = objs[0];
    Ok(goto(obj.kind, obj.color).into())
}

/// `GoToLocal`: the paper's go-to level (and, with `task` Pickup, its pick-up twin; see
/// docs/world.md).
pub fn local(g: &mut Gen, num_dists: usize, task: TaskKind) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    let objs = g.add_distractors(None, None, num_dists, false)?;
    g.check_objs_reachable()?;
    let obj = g.rand_elem(&objs);
    Ok(Instr::from(Instruction::new(
        task,
        desc(Some(obj.kind), Some(obj.color)),
    ))
    .into())
}

/// The paper's level: `GoToLocal`, then (go to and pick up) the task drawn as
/// `_rand_elem(["goto", "pickup"])`, then (colour optional) the colour left out when
/// `_rand_int(0, 7) == 0`. With go-to only and the colour always named it is
/// `BabyAI-GoToLocalS{S}N{N}-v0` exactly; docs/world.md has the Python.
pub fn paper(
    g: &mut Gen,
    num_dists: usize,
    tasks: TaskSet,
    color_optional: bool,
) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    let objs = g.add_distractors(None, None, num_dists, false)?;
    g.check_objs_reachable()?;
    let obj = g.rand_elem(&objs);
    let task = g.rand_elem(tasks.kinds());
    let mut color = Some(obj.color);
    if color_optional && g.rand_int(0, 7) == 0 {
        color = None;
    }
    Ok(Instr::from(Instruction::new(task, desc(Some(obj.kind), color))).into())
}

/// `GoTo`: several rooms connected by doors.
pub fn maze(g: &mut Gen, num_dists: usize, doors_open: bool) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    g.connect_all(&COLOR_NAMES)?;
    let objs = g.add_distractors(None, None, num_dists, false)?;
    g.check_objs_reachable()?;
    let obj = g.rand_elem(&objs);
    if doors_open {
        g.open_all_doors();
    }
    Ok(goto(obj.kind, obj.color).into())
}

/// `GoToImpUnlock`: the target sits behind a locked door whose key is somewhere. Python's
/// `ik is id` compares two numpy integers by identity, never true: the key may land in the
/// locked room, and every room gets distractors.
pub fn imp_unlock(g: &mut Gen) -> Result<Generated, Retry> {
    let (cols, rows) = (g.rooms.num_cols, g.rooms.num_rows);
    let (_, (id, jd)) = super::unlock::locked_door_and_key(g)?;
    g.connect_all(&COLOR_NAMES)?;
    for i in 0..cols {
        for j in 0..rows {
            g.add_distractors(Some(i), Some(j), 2, false)?;
        }
    }
    g.place_agent_outside(Some(g.room_index(id, jd)))?;
    g.check_objs_reachable()?;
    let objs = g.add_distractors(Some(id), Some(jd), 1, false)?;
    let obj = objs[0];
    Ok(goto(obj.kind, obj.color).into())
}

/// `GoToRedBlueBall`: one red or blue ball among distractors that are neither.
pub fn red_blue_ball(g: &mut Gen, num_dists: usize) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    let dists = g.add_distractors(None, None, num_dists, false)?;
    if dists
        .iter()
        .any(|d| d.kind == ObjectKind::Ball && matches!(d.color, Color::Blue | Color::Red))
    {
        return Err(Retry::Reject("can only have one blue or red ball"));
    }
    let color = g.rand_elem(&[Color::Red, Color::Blue]);
    let (obj, _) = g.add_object(0, 0, Some(ObjectKind::Ball), Some(color))?;
    g.check_objs_reachable()?;
    Ok(goto(obj.kind, obj.color).into())
}

/// `GoToDoor`: four doors of the middle room (possibly locked), go to one by colour.
pub fn door(g: &mut Gen) -> Result<Generated, Retry> {
    let mut doors = Vec::with_capacity(4);
    for _ in 0..4 {
        let (d, _) = g.add_door(1, 1, None, None, None);
        doors.push(d);
    }
    g.place_agent(Some(1), Some(1))?;
    let obj = g.rand_elem(&doors);
    Ok(goto(ObjectKind::Door, obj.color).into())
}

/// `GoToObjDoor`: eight objects and four doors in the middle room.
pub fn obj_door(g: &mut Gen) -> Result<Generated, Retry> {
    g.place_agent(Some(1), Some(1))?;
    let mut objs = g.add_distractors(Some(1), Some(1), 8, false)?;
    for _ in 0..4 {
        let (d, _) = g.add_door(1, 1, None, None, None);
        objs.push(d);
    }
    g.check_objs_reachable()?;
    let obj = g.rand_elem(&objs);
    Ok(goto(obj.kind, obj.color).into())
}

/// `Open`: open one of the doors `connect_all` made, among 18 distractors.
pub fn open_any(g: &mut Gen) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    g.connect_all(&COLOR_NAMES)?;
    g.add_distractors(None, None, 18, false)?;
    g.check_objs_reachable()?;
    let doors = door_list(g);
    let (_, color) = g.rand_elem(&doors);
    Ok(Instr::from(Instruction::new(
        TaskKind::Open,
        desc(Some(ObjectKind::Door), Some(color)),
    ))
    .into())
}
