//! The PutNext family (`minigrid/envs/babyai/putnext.py`) and `MoveTwoAcross`.

use super::roomgrid::{Gen, Retry};
use super::{Generated, Objects, desc};
use crate::env::grid::Pos;
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

/// The grid's objects in scan order (x-major), where a level placed them all itself: its
/// validation and the verifier's reset then need no scan of the grid.
fn scan_order(mut placed: Vec<(Pos, WorldObj)>) -> Objects {
    placed.sort_unstable_by_key(|&(pos, _)| pos);
    placed
}

/// `PutNextLocal`: two of `num_objs` unique objects.
pub fn local(g: &mut Gen, num_objs: usize) -> Result<Generated, Retry> {
    g.place_agent(None, None)?;
    let placed = g.add_distractors_placed(None, None, num_objs, true)?;
    g.check_objs_reachable()?;
    // Drawn from the (position, object) pairs: the draws depend on the list's length only.
    let pick = g.rand_subset(&placed, 2);
    let mut out = Generated::from(put(pick[0].1, pick[1].1));
    out.objects = Some(scan_order(placed));
    Ok(out)
}

/// `PutNext`: an object of one room next to one of the other, the wall between them
/// removed; with `start_carrying` the agent holds the first after the first observation.
pub fn two_rooms(
    g: &mut Gen,
    objs_per_room: usize,
    start_carrying: bool,
) -> Result<Generated, Retry> {
    g.place_agent(Some(0), Some(0))?;
    let mut placed = g.add_distractors_placed(Some(0), Some(0), objs_per_room, true)?;
    let right = g.add_distractors_placed(Some(1), Some(0), objs_per_room, true)?;
    g.remove_wall(0, 0, 0);
    let (_, mut a) = g.rand_elem(&placed);
    let (_, mut b) = g.rand_elem(&right);
    if g.rand_bool() {
        std::mem::swap(&mut a, &mut b);
    }
    let mut out = Generated::from(put(a, b));
    if start_carrying {
        out.lift = Some(a.id);
    }
    placed.extend(right);
    out.objects = Some(scan_order(placed));
    Ok(out)
}

/// `MoveTwoAcross`: two PutNext clauses across the two rooms, in order.
pub fn move_two_across(g: &mut Gen, objs_per_room: usize) -> Result<Generated, Retry> {
    g.place_agent(Some(0), Some(0))?;
    let mut placed = g.add_distractors_placed(Some(0), Some(0), objs_per_room, true)?;
    let right = g.add_distractors_placed(Some(1), Some(0), objs_per_room, true)?;
    g.remove_wall(0, 0, 0);
    let l = g.rand_subset(&placed, 2);
    let r = g.rand_subset(&right, 2);
    let mut out = Generated::from(Instr::seq(
        SeqKind::Before,
        put(l[0].1, r[0].1),
        put(r[1].1, l[1].1),
    ));
    placed.extend(right);
    out.objects = Some(scan_order(placed));
    Ok(out)
}
