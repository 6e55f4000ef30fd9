//! The PutNext family (`minigrid/envs/babyai/putnext.py`) and `MoveTwoAcross`.

use super::roomgrid::{Gen, Retry};
use super::{Generated, desc};
use crate::env::instr::{Instr, SeqKind};
use crate::env::mission::Instruction;
use crate::env::object::WorldObj;

fn put(a: WorldObj, b: WorldObj) -> Instr {
    Instruction::put_next(
        desc(Some(a.kind), Some(a.color)),
        desc(Some(b.kind), Some(b.color)),
    )
    .into()
}

/// `PutNextLocal`: two of `num_objs` unique objects.
pub fn local(g: &mut Gen, num_objs: usize) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    let objs = g.add_distractors(None, None, num_objs, true)?;
    g.check_objs_reachable()?;
    let pick = g.rand_subset(&objs, 2);
    Ok(put(pick[0], pick[1]).into())
}

/// `PutNext`: an object of one room next to one of the other, the wall between them
/// removed; with `start_carrying` the agent holds the first after the first observation.
pub fn two_rooms(
    g: &mut Gen,
    objs_per_room: usize,
    start_carrying: bool,
) -> Result<Generated, Retry> {
    g.place_agent(Some(0), Some(0))?;
    let left = g.add_distractors(Some(0), Some(0), objs_per_room, true)?;
    let right = g.add_distractors(Some(1), Some(0), objs_per_room, true)?;
    g.remove_wall(0, 0, 0);
    let mut a = g.rand_elem(&left);
    let mut b = g.rand_elem(&right);
    if g.rand_bool() {
        std::mem::swap(&mut a, &mut b);
    }
    let mut out = Generated::from(put(a, b));
    if start_carrying {
        out.lift = Some(a.id);
    }
    Ok(out)
}

/// `MoveTwoAcross`: two PutNext clauses across the two rooms, in order.
pub fn move_two_across(g: &mut Gen, objs_per_room: usize) -> Result<Generated, Retry> {
    g.place_agent(Some(0), Some(0))?;
    let left = g.add_distractors(Some(0), Some(0), objs_per_room, true)?;
    let right = g.add_distractors(Some(1), Some(0), objs_per_room, true)?;
    g.remove_wall(0, 0, 0);
    let l = g.rand_subset(&left, 2);
    let r = g.rand_subset(&right, 2);
    Ok(Instr::seq(SeqKind::Before, put(l[0], r[0]), put(r[1], l[1])).into())
}
