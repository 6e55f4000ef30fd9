//! The instruction tree of a snapshot: its JSON form read back into a verifier
//! ([`instr_from_json`]) and written from one ([`instr_to_json`]), with the positions a dump
//! lists as matched.

use super::{DescJson, InstrJson, invalid, pos_of};
use crate::env::error::EnvError;
use crate::env::grid::{Grid, Pos};
use crate::env::instr::{Instr, SeqKind, Targets};
use crate::env::mission::{Instruction, Loc, ObjDesc, TaskKind};
use crate::env::object::{Color, ObjectKind, WorldObj};
use crate::env::world::World;

fn name_opt<T>(
    name: Option<&String>,
    field: &str,
    what: &str,
    parse: impl Fn(&str) -> Option<T>,
) -> Result<Option<T>, EnvError> {
    match name {
        None => Ok(None),
        Some(n) => parse(n)
            .map(Some)
            .ok_or_else(|| invalid(field, format!("{n:?} is not {what}"))),
    }
}

fn desc_from(
    kind: Option<&String>,
    color: Option<&String>,
    loc: Option<&String>,
    field: &str,
) -> Result<ObjDesc, EnvError> {
    Ok(ObjDesc {
        kind: name_opt(
            kind,
            &format!("{field}.type"),
            "key, ball, box or door",
            |t| ObjectKind::from_name(t).filter(|k| k.can_pickup() || *k == ObjectKind::Door),
        )?,
        color: name_opt(
            color,
            &format!("{field}.color"),
            "a colour",
            Color::from_name,
        )?,
        loc: name_opt(loc, &format!("{field}.loc"), "a location", Loc::from_name)?,
    })
}

/// The instruction tree a dump describes (verifier state fresh).
pub fn instr_from_json(j: &InstrJson, field: &str) -> Result<Instr, EnvError> {
    if let Some(kind) = SeqKind::from_class(&j.kind) {
        let (Some(a), Some(b)) = (&j.a, &j.b) else {
            return Err(invalid(field, format!("{} needs parts a and b", j.kind)));
        };
        let a = instr_from_json(a, &format!("{field}.a"))?;
        let b = instr_from_json(b, &format!("{field}.b"))?;
        if kind == SeqKind::And && (matches!(a, Instr::Seq(_)) || matches!(b, Instr::Seq(_))) {
            return Err(invalid(field, "AndInstr joins two action clauses"));
        }
        if let (Instr::Seq(x), _) | (_, Instr::Seq(x)) = (&a, &b)
            && x.kind != SeqKind::And
        {
            return Err(invalid(field, "a sequence's parts are clauses or AndInstr"));
        }
        let mut tree = Instr::seq(kind, a, b);
        if let Instr::Seq(s) = &mut tree {
            s.strict = j.strict.unwrap_or(false);
        }
        return Ok(tree);
    }
    let Some(task) = TaskKind::from_class(&j.kind) else {
        return Err(invalid(
            format!("{field}.kind"),
            format!(
                "{:?} is not GoToInstr, PickupInstr, OpenInstr, PutNextInstr, AndInstr, \
                 BeforeInstr or AfterInstr",
                j.kind
            ),
        ));
    };
    let mut instr = if task == TaskKind::PutNext {
        let (Some(m), Some(f)) = (&j.moved, &j.fixed) else {
            return Err(invalid(field, "PutNextInstr needs move and fixed"));
        };
        let moved = desc_from(
            m.kind_name.as_ref(),
            m.color.as_ref(),
            m.loc.as_ref(),
            &format!("{field}.move"),
        )?;
        let fixed = desc_from(
            f.kind_name.as_ref(),
            f.color.as_ref(),
            f.loc.as_ref(),
            &format!("{field}.fixed"),
        )?;
        if moved.kind == Some(ObjectKind::Door) {
            return Err(invalid(
                format!("{field}.move.type"),
                "a door cannot be moved",
            ));
        }
        Instruction::put_next(moved, fixed)
    } else {
        let desc = desc_from(
            j.kind_name.as_ref(),
            j.color.as_ref(),
            j.loc.as_ref(),
            field,
        )?;
        let door = desc.kind == Some(ObjectKind::Door);
        if (task == TaskKind::Open) != door && !(task == TaskKind::GoTo && door) {
            return Err(invalid(
                format!("{field}.type"),
                format!(
                    "{} cannot act on {}",
                    j.kind,
                    desc.kind.map_or("object", ObjectKind::name)
                ),
            ));
        }
        Instruction::new(task, desc)
    };
    instr.strict = j.strict.unwrap_or(false);
    Ok(instr.into())
}

fn desc_json(desc: ObjDesc, poss: &[Pos]) -> DescJson {
    DescJson {
        kind_name: desc.kind.map(|k| k.name().into()),
        color: desc.color.map(|c| c.name().into()),
        loc: desc.loc.map(|l| l.name().into()),
        match_positions: poss
            .iter()
            .map(|p| [i64::from(p.0), i64::from(p.1)])
            .collect(),
    }
}

/// The dump form of an instruction tree, with each description's current positions.
pub fn instr_to_json(tree: &Instr) -> InstrJson {
    let empty = InstrJson {
        kind: String::new(),
        kind_name: None,
        color: None,
        loc: None,
        match_positions: Vec::new(),
        strict: None,
        moved: None,
        fixed: None,
        a: None,
        b: None,
    };
    match tree {
        Instr::Seq(s) => InstrJson {
            kind: s.kind.instr_class().into(),
            strict: Some(s.strict),
            a: Some(Box::new(instr_to_json(&s.a))),
            b: Some(Box::new(instr_to_json(&s.b))),
            ..empty
        },
        Instr::Action(n) => {
            let strict = (n.instr.task != TaskKind::GoTo).then_some(n.instr.strict);
            let kind = n.instr.task.instr_class().into();
            if let Some(fixed) = n.instr.fixed {
                return InstrJson {
                    kind,
                    strict,
                    moved: Some(desc_json(n.instr.desc, &n.targets.obj_poss)),
                    fixed: Some(desc_json(fixed, &n.fixed_targets.obj_poss)),
                    ..empty
                };
            }
            let d = desc_json(n.instr.desc, &n.targets.obj_poss);
            InstrJson {
                kind,
                kind_name: d.kind_name,
                color: d.color,
                loc: d.loc,
                match_positions: d.match_positions,
                strict,
                ..empty
            }
        }
    }
}

/// Replaces each clause's targets by the objects at the dump's match positions (a snapshot
/// taken mid-episode lists where they are now), checking that each matches its description.
pub(super) fn override_targets(world: &mut World, j: &InstrJson) -> Result<(), EnvError> {
    let grid = world.grid.clone();
    let carried = world.carrying.filter(|_| world.reset_floor.is_some());
    let floor = world.reset_floor;
    set_targets(&mut world.instr, j, "instr", &grid, carried, floor)
}

fn resolve(
    d: &DescJson,
    desc: ObjDesc,
    field: &str,
    grid: &Grid,
    carried: Option<WorldObj>,
    floor: Option<Pos>,
) -> Result<Targets, EnvError> {
    let mut t = Targets::default();
    for (i, p) in d.match_positions.iter().enumerate() {
        let f = format!("{field}.match_positions[{i}]");
        let pos = pos_of(*p, &f)?;
        match grid.get(pos) {
            Some(o) if desc.matches(&o) => t.obj_set.push(o.id),
            Some(o) => {
                return Err(invalid(
                    f,
                    format!("{pos:?} holds a {}, which does not match", o.describe()),
                ));
            }
            None => match carried {
                Some(c) if Some(pos) == floor && desc.matches(&c) => t.obj_set.push(c.id),
                _ => return Err(invalid(f, format!("{pos:?} holds no object"))),
            },
        }
        t.obj_poss.push(pos);
    }
    Ok(t)
}

fn set_targets(
    tree: &mut Instr,
    j: &InstrJson,
    field: &str,
    grid: &Grid,
    carried: Option<WorldObj>,
    floor: Option<Pos>,
) -> Result<(), EnvError> {
    match tree {
        Instr::Seq(s) => {
            let (Some(a), Some(b)) = (&j.a, &j.b) else {
                return Err(invalid(field, "a sequence needs parts a and b"));
            };
            set_targets(&mut s.a, a, &format!("{field}.a"), grid, carried, floor)?;
            set_targets(&mut s.b, b, &format!("{field}.b"), grid, carried, floor)
        }
        Instr::Action(n) => {
            if let (Some(fixed), Some(m), Some(f)) = (n.instr.fixed, &j.moved, &j.fixed) {
                n.targets = resolve(
                    m,
                    n.instr.desc,
                    &format!("{field}.move"),
                    grid,
                    carried,
                    floor,
                )?;
                n.fixed_targets =
                    resolve(f, fixed, &format!("{field}.fixed"), grid, carried, floor)?;
            } else {
                let d = DescJson {
                    kind_name: j.kind_name.clone(),
                    color: j.color.clone(),
                    loc: j.loc.clone(),
                    match_positions: j.match_positions.clone(),
                };
                n.targets = resolve(&d, n.instr.desc, field, grid, carried, floor)?;
            }
            if n.targets.obj_set.is_empty() {
                return Err(invalid(field, "no object matches the description"));
            }
            Ok(())
        }
    }
}
