//! The Open family (`minigrid/envs/babyai/open.py`; `Open` itself is in [`super::goto`]'s
//! neighbour, [`super::goto::open_any`], as it shares GoTo's maze).

use super::roomgrid::{COLOR_NAMES, Gen, Retry};
use super::{Generated, desc};
use crate::env::instr::{Instr, SeqKind};
use crate::env::mission::{Instruction, Loc, ObjDesc, TaskKind};
use crate::env::object::{Color, ObjectKind};

/// `LOC_NAMES`.
pub const LOC_NAMES: [Loc; 4] = [Loc::Left, Loc::Right, Loc::Front, Loc::Behind];

fn open(d: ObjDesc, strict: bool) -> Instr {
    let mut i = Instruction::new(TaskKind::Open, d);
    i.strict = strict;
    i.into()
}

fn door_desc(color: Color) -> ObjDesc {
    desc(Some(ObjectKind::Door), Some(color))
}

/// `OpenRedDoor`: two rooms, one red door.
pub fn red_door(g: &mut Gen) -> Result<Generated, Retry> {
    g.add_door(0, 0, Some(0), Some(Color::Red), Some(false));
    g.place_agent(Some(0), Some(0))?;
    Ok(open(door_desc(Color::Red), false).into())
}

/// How `OpenDoor` names the door.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SelectBy {
    /// By colour.
    Color,
    /// By location.
    Loc,
}

/// `OpenDoor`: four doors of distinct colours around the middle room; open the first, named
/// by colour or by location.
pub fn door(g: &mut Gen, debug: bool, select_by: Option<SelectBy>) -> Result<Generated, Retry> {
    let colors = g.rand_subset(&COLOR_NAMES, 4);
    let mut doors = Vec::with_capacity(4);
    for (k, color) in colors.into_iter().enumerate() {
        let (d, _) = g.add_door(1, 1, Some(k), Some(color), Some(false));
        doors.push(d);
    }
    let select_by = match select_by {
        Some(s) => s,
        None => g.rand_elem(&[SelectBy::Color, SelectBy::Loc]),
    };
    let d = match select_by {
        SelectBy::Color => door_desc(doors[0].color),
        SelectBy::Loc => ObjDesc {
            kind: Some(ObjectKind::Door),
            color: None,
            loc: Some(g.rand_elem(&LOC_NAMES)),
        },
    };
    g.place_agent(Some(1), Some(1))?;
    Ok(open(d, debug).into())
}

/// `OpenTwoDoors`: open the door on the left wall, then the one on the right.
pub fn two_doors(
    g: &mut Gen,
    first: Option<Color>,
    second: Option<Color>,
    strict: bool,
) -> Result<Generated, Retry> {
    let colors = g.rand_subset(&COLOR_NAMES, 2);
    let first = first.unwrap_or(colors[0]);
    let second = second.unwrap_or(colors[1]);
    let (d1, _) = g.add_door(1, 1, Some(2), Some(first), Some(false));
    let (d2, _) = g.add_door(1, 1, Some(0), Some(second), Some(false));
    g.place_agent(Some(1), Some(1))?;
    Ok(Instr::seq(
        SeqKind::Before,
        open(door_desc(d1.color), strict),
        open(door_desc(d2.color), false),
    )
    .into())
}

/// `OpenDoorsOrder`: `num_doors` doors; open one, or two in an order.
pub fn doors_order(g: &mut Gen, num_doors: usize, debug: bool) -> Result<Generated, Retry> {
    let colors = g.rand_subset(&COLOR_NAMES, num_doors);
    let mut doors = Vec::with_capacity(num_doors);
    for &color in &colors {
        let (d, _) = g.add_door(1, 1, None, Some(color), Some(false));
        doors.push(d);
    }
    g.place_agent(Some(1), Some(1))?;
    let pick = g.rand_subset(&doors, 2);
    let (d1, d2) = (door_desc(pick[0].color), door_desc(pick[1].color));
    let mode = g.rand_int(0, 3);
    Ok(match mode {
        0 => open(d1, debug),
        1 => Instr::seq(SeqKind::Before, open(d1, debug), open(d2, debug)),
        _ => Instr::seq(SeqKind::After, open(d1, debug), open(d2, debug)),
    }
    .into())
}
