//! One room of named objects: Fetch, GoToObject, GoToDoor and PutNear
//! (`minigrid/envs/{fetch,gotoobject,gotodoor,putnear}.py`).

use super::{INF_TRIES, Made, Rules, clause, desc};
use crate::env::babyai::roomgrid::{COLOR_NAMES, Gen, Retry};
use crate::env::grid::Pos;
use crate::env::instr::Instr;
use crate::env::mission::{Instruction, TaskKind};
use crate::env::object::{Color, ObjectKind};

const KEY_BALL: [ObjectKind; 2] = [ObjectKind::Key, ObjectKind::Ball];
const KEY_BALL_BOX: [ObjectKind; 3] = [ObjectKind::Key, ObjectKind::Ball, ObjectKind::Box];

/// The outer walls as Fetch and PutNear draw them (four walls, not `wall_rect`).
fn outer_walls(g: &mut Gen) {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.horz_wall(0, 0, None, ObjectKind::Wall);
    g.horz_wall(0, h - 1, None, ObjectKind::Wall);
    g.vert_wall(0, 0, None, ObjectKind::Wall);
    g.vert_wall(w - 1, 0, None, ObjectKind::Wall);
}

/// `FetchEnv._gen_grid`: keys and balls (repeats allowed), the agent, a target among them
/// and one of five phrasings.
pub fn fetch(g: &mut Gen, num_objs: usize) -> Result<Made, Retry> {
    outer_walls(g);
    let mut objs = Vec::with_capacity(num_objs);
    while objs.len() < num_objs {
        let kind = g.rand_elem(&KEY_BALL);
        let color = g.rand_elem(&COLOR_NAMES);
        let obj = g.obj(kind, color);
        g.place_anywhere(obj)?;
        objs.push(obj);
    }
    g.place_agent_in(None, None)?;
    let target = objs[g.rng.below(0, objs.len())];
    let syntax = [
        "get a",
        "go get a",
        "fetch a",
        "go fetch a",
        "you must fetch a",
    ];
    let phrase = syntax[g.rng.below(0, 5)];
    Ok(Made {
        mission: format!("{phrase} {} {}", target.color, target.kind),
        rules: Rules::Fetch {
            kind: target.kind,
            color: target.color,
        },
        instr: clause(TaskKind::Pickup, target.kind, target.color),
    })
}

/// Distinct `(type, colour)` pairs drawn type first, each placed with `reject` (PutNear:
/// not beside an earlier one); returns them with their cells.
fn distinct_objects(
    g: &mut Gen,
    n: usize,
    apart: bool,
) -> Result<Vec<(ObjectKind, Color, Pos)>, Retry> {
    let mut objs: Vec<(ObjectKind, Color, Pos)> = Vec::with_capacity(n);
    while objs.len() < n {
        let kind = g.rand_elem(&KEY_BALL_BOX);
        let color = g.rand_elem(&COLOR_NAMES);
        if objs.iter().any(|o| o.0 == kind && o.1 == color) {
            continue;
        }
        let obj = g.obj(kind, color);
        let placed: Vec<Pos> = objs.iter().map(|o| o.2).collect();
        let near = |p: Pos| {
            apart
                && placed
                    .iter()
                    .any(|q| (p.0 - q.0).abs() <= 1 && (p.1 - q.1).abs() <= 1)
        };
        let size = (g.grid.width() as i32, g.grid.height() as i32);
        let pos = g.place_obj_with(Some(obj), (0, 0), size, near, INF_TRIES)?;
        objs.push((kind, color, pos));
    }
    Ok(objs)
}

/// `GoToObjectEnv._gen_grid`: distinct keys, balls and boxes; `done` beside the target.
pub fn go_to_object(g: &mut Gen, num_objs: usize) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.wall_rect(0, 0, w, h);
    let objs = distinct_objects(g, num_objs, false)?;
    g.place_agent_in(None, None)?;
    let (kind, color, target) = objs[g.rng.below(0, objs.len())];
    Ok(Made {
        mission: format!("go to the {color} {kind}"),
        rules: Rules::GoToCell { target },
        instr: clause(TaskKind::GoTo, kind, color),
    })
}

/// `GoToDoorEnv._gen_grid`: a room of random size inside the grid with a door of a distinct
/// colour in each wall; `done` beside the named one.
pub fn go_to_door(g: &mut Gen) -> Result<Made, Retry> {
    let (gw, gh) = (g.grid.width() as i32, g.grid.height() as i32);
    let w = g.rand_int(5, gw + 1);
    let h = g.rand_int(5, gh + 1);
    g.wall_rect(0, 0, w, h);
    let doors: [Pos; 4] = [
        (g.rand_int(2, w - 2), 0),
        (g.rand_int(2, w - 2), h - 1),
        (0, g.rand_int(2, h - 2)),
        (w - 1, g.rand_int(2, h - 2)),
    ];
    let mut colors: Vec<Color> = Vec::with_capacity(4);
    while colors.len() < doors.len() {
        let c = g.rand_elem(&COLOR_NAMES);
        if !colors.contains(&c) {
            colors.push(c);
        }
    }
    for (pos, color) in doors.iter().zip(&colors) {
        g.put_door(*pos, *color, false);
    }
    g.place_agent_in(None, Some((w, h)))?;
    let i = g.rng.below(0, doors.len());
    Ok(Made {
        mission: format!("go to the {} door", colors[i]),
        rules: Rules::GoToCell { target: doors[i] },
        instr: clause(TaskKind::GoTo, ObjectKind::Door, colors[i]),
    })
}

/// `PutNearEnv._gen_grid`: distinct objects none beside another, an object to move and a
/// target, both drawn after the agent.
pub fn put_near(g: &mut Gen, num_objs: usize) -> Result<Made, Retry> {
    outer_walls(g);
    let objs = distinct_objects(g, num_objs, true)?;
    g.place_agent_in(None, None)?;
    let moved = g.rng.below(0, objs.len());
    let target = loop {
        let t = g.rng.below(0, objs.len());
        if t != moved {
            break t;
        }
    };
    let (mk, mc, _) = objs[moved];
    let (tk, tc, tpos) = objs[target];
    let instr: Instr = Instruction::put_next(desc(mk, Some(mc)), desc(tk, Some(tc))).into();
    Ok(Made {
        mission: format!("put the {mc} {mk} near the {tc} {tk}"),
        rules: Rules::PutNear {
            kind: mk,
            color: mc,
            target: tpos,
        },
        instr,
    })
}
