//! The Pickup family (`minigrid/envs/babyai/pickup.py`).

use super::roomgrid::{COLOR_NAMES, Gen, Retry};
use super::{Generated, desc};
use crate::env::instr::Instr;
use crate::env::mission::{Instruction, TaskKind};

fn pickup(d: crate::env::mission::ObjDesc, strict: bool) -> Instr {
    let mut i = Instruction::new(TaskKind::Pickup, d);
    i.strict = strict;
    i.into()
}

/// `Pickup`: any object of the nine-room maze.
pub fn maze(g: &mut Gen) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    g.connect_all(&COLOR_NAMES)?;
    let objs = g.add_distractors(None, None, 18, false)?;
    g.check_objs_reachable()?;
    let obj = g.rand_elem(&objs);
    Ok(pickup(desc(Some(obj.kind), Some(obj.color)), false).into())
}

/// `UnblockPickup`: like `Pickup` with 20 objects, kept only when one blocks the way.
pub fn unblock(g: &mut Gen) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    g.connect_all(&COLOR_NAMES)?;
    let objs = g.add_distractors(None, None, 20, false)?;
    if g.objs_reachable() {
        return Err(Retry::Reject("all objects reachable"));
    }
    let obj = g.rand_elem(&objs);
    Ok(pickup(desc(Some(obj.kind), Some(obj.color)), false).into())
}

/// `PickupDist`: five unique objects; named by type, colour or both.
pub fn dist(g: &mut Gen, debug: bool) -> Result<Generated, Retry> {
    let objs = g.add_distractors(None, None, 5, true)?;
    g.place_agent(Some(0), Some(0))?;
    let obj = g.rand_elem(&objs);
    let by = g.rand_elem(&["type", "color", "both"]);
    let kind = (by != "color").then_some(obj.kind);
    let color = (by != "type").then_some(obj.color);
    Ok(pickup(desc(kind, color), debug).into())
}

/// `PickupAbove`: the object is in the room above the agent's.
pub fn above(g: &mut Gen) -> Result<Generated, Retry> {
    let (obj, _) = g.add_object(1, 0, None, None)?;
    g.add_door(1, 1, Some(3), None, Some(false));
    g.place_agent(Some(1), Some(1))?;
    g.connect_all(&COLOR_NAMES)?;
    Ok(pickup(desc(Some(obj.kind), Some(obj.color)), false).into())
}
