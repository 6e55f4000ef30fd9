//! Hand-built layouts: MultiRoom, LockedRoom, Playground, RedBlueDoors and Memory
//! (`minigrid/envs/{multiroom,lockedroom,playground,redbluedoors,memory}.py`).

use super::{INF_TRIES, Made, Rules, clause, to_goal};
use crate::env::babyai::roomgrid::{COLOR_NAMES, DISTRACTOR_TYPES, Gen, Retry};
use crate::env::grid::Pos;
use crate::env::instr::{Instr, SeqKind};
use crate::env::mission::TaskKind;
use crate::env::object::{Color, ObjectKind};

/// MultiRoom's chain attempts before generation gives up (minigrid retries forever; the
/// registered sizes need a handful).
const MULTIROOM_ATTEMPTS: u32 = 100_000;

/// A room of the chain: top-left corner, size and entry door.
#[derive(Clone, Copy)]
struct Room {
    top: Pos,
    size: (i32, i32),
    entry: Pos,
}

/// `MultiRoomEnv._gen_grid`: the longest chain of rooms found (at least the drawn number),
/// each entered by a door of a colour other than the previous door's.
pub fn multi_room(
    g: &mut Gen,
    min_rooms: i32,
    max_rooms: i32,
    max_size: i32,
) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    let num_rooms = g.rand_int(min_rooms, max_rooms + 1) as usize;
    let mut rooms: Vec<Room> = Vec::new();
    let mut attempts = 0;
    while rooms.len() < num_rooms {
        attempts += 1;
        if attempts > MULTIROOM_ATTEMPTS {
            return Err(Retry::Endless(
                "MultiRoom: no chain of that many rooms fits the grid, so minigrid draws forever",
            ));
        }
        let mut cur = Vec::new();
        // Both coordinates are drawn below `width - 2`, as minigrid does.
        let entry = (g.rand_int(0, w - 2), g.rand_int(0, w - 2));
        place_room(g, (w, h), num_rooms, &mut cur, (4, max_size), 2, entry);
        if cur.len() > rooms.len() {
            rooms = cur;
        }
    }
    let mut prev_color: Option<Color> = None;
    for (idx, room) in rooms.iter().enumerate() {
        let ((tx, ty), (sx, sy)) = (room.top, room.size);
        for i in 0..sx {
            g.put((tx + i, ty), ObjectKind::Wall, Color::Grey);
            g.put((tx + i, ty + sy - 1), ObjectKind::Wall, Color::Grey);
        }
        for j in 0..sy {
            g.put((tx, ty + j), ObjectKind::Wall, Color::Grey);
            g.put((tx + sx - 1, ty + j), ObjectKind::Wall, Color::Grey);
        }
        if idx > 0 {
            let colors: Vec<Color> = COLOR_NAMES
                .into_iter()
                .filter(|c| Some(*c) != prev_color)
                .collect();
            let color = g.rand_elem(&colors);
            g.put_door(room.entry, color, false);
            prev_color = Some(color);
        }
    }
    let (first, last) = (rooms[0], rooms[rooms.len() - 1]);
    g.place_agent_in(Some(first.top), Some(first.size))?;
    let goal = g.obj(ObjectKind::Goal, Color::Green);
    g.place_obj(Some(goal), last.top, last.size, false, INF_TRIES)?;
    Ok(Made {
        mission: "traverse the rooms to get to the goal".to_owned(),
        rules: Rules::Plain,
        instr: to_goal(),
    })
}

/// `_placeRoom`: a room of random size entered through `entry` on wall `entry_wall`, then up
/// to 8 tries at the next room through a random other wall. `false` when this room does not
/// fit (nothing appended).
fn place_room(
    g: &mut Gen,
    (w, h): (i32, i32),
    num_left: usize,
    rooms: &mut Vec<Room>,
    (min_sz, max_sz): (i32, i32),
    entry_wall: usize,
    entry: Pos,
) -> bool {
    let sx = g.rand_int(min_sz, max_sz + 1);
    let sy = g.rand_int(min_sz, max_sz + 1);
    let (tx, ty) = if rooms.is_empty() {
        entry
    } else {
        match entry_wall {
            0 => (entry.0 - sx + 1, g.rand_int(entry.1 - sy + 2, entry.1)),
            1 => (g.rand_int(entry.0 - sx + 2, entry.0), entry.1 - sy + 1),
            2 => (entry.0, g.rand_int(entry.1 - sy + 2, entry.1)),
            _ => (g.rand_int(entry.0 - sx + 2, entry.0), entry.1),
        }
    };
    if tx < 0 || ty < 0 || tx + sx > w || ty + sy >= h {
        return false;
    }
    let before = rooms.len().saturating_sub(1);
    for r in &rooms[..before] {
        let apart = tx + sx < r.top.0
            || r.top.0 + r.size.0 <= tx
            || ty + sy < r.top.1
            || r.top.1 + r.size.1 <= ty;
        if !apart {
            return false;
        }
    }
    rooms.push(Room {
        top: (tx, ty),
        size: (sx, sy),
        entry,
    });
    if num_left == 1 {
        return true;
    }
    for _ in 0..8 {
        let walls: Vec<usize> = (0..4).filter(|k| *k != entry_wall).collect();
        let exit_wall = g.rand_elem(&walls);
        let next_entry = (exit_wall + 2) % 4;
        let exit = match exit_wall {
            0 => (tx + sx - 1, ty + g.rand_int(1, sy - 1)),
            1 => (tx + g.rand_int(1, sx - 1), ty + sy - 1),
            2 => (tx, ty + g.rand_int(1, sy - 1)),
            _ => (tx + g.rand_int(1, sx - 1), ty),
        };
        if place_room(
            g,
            (w, h),
            num_left - 1,
            rooms,
            (min_sz, max_sz),
            next_entry,
            exit,
        ) {
            break;
        }
    }
    true
}

/// `LockedRoomEnv._gen_grid`: six side rooms off a corridor, one locked with the goal inside,
/// its key in another.
pub fn locked_room(g: &mut Gen) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    let wall = |g: &mut Gen, p: Pos| {
        g.put(p, ObjectKind::Wall, Color::Grey);
    };
    for i in 0..w {
        wall(g, (i, 0));
        wall(g, (i, h - 1));
    }
    for j in 0..h {
        wall(g, (0, j));
        wall(g, (w - 1, j));
    }
    let (l, r) = (w / 2 - 2, w / 2 + 2);
    for j in 0..h {
        wall(g, (l, j));
        wall(g, (r, j));
    }
    // (top, size, door)
    let mut rooms: Vec<(Pos, (i32, i32), Pos)> = Vec::with_capacity(6);
    for n in 0..3 {
        let j = n * (h / 3);
        for i in 0..l {
            wall(g, (i, j));
        }
        for i in r..w {
            wall(g, (i, j));
        }
        let size = (l + 1, h / 3 + 1);
        rooms.push(((0, j), size, (l, j + 3)));
        rooms.push(((r, j), size, (r, j + 3)));
    }
    let rand_pos = |g: &mut Gen, (top, size, _): (Pos, (i32, i32), Pos)| {
        let x = g.rand_int(top.0 + 1, top.0 + size.0 - 1);
        let y = g.rand_int(top.1 + 1, top.1 + size.1 - 1);
        (x, y)
    };
    let locked = g.rng.below(0, rooms.len());
    let goal = rand_pos(g, rooms[locked]);
    g.put(goal, ObjectKind::Goal, Color::Green);
    let mut left = COLOR_NAMES.to_vec();
    let mut colors = Vec::with_capacity(rooms.len());
    for (k, room) in rooms.iter().enumerate() {
        let c = left.remove(g.rng.below(0, left.len()));
        colors.push(c);
        g.put_door(room.2, c, k == locked);
    }
    let key_room = loop {
        let k = g.rng.below(0, rooms.len());
        if k != locked {
            break k;
        }
    };
    let key = rand_pos(g, rooms[key_room]);
    g.put(key, ObjectKind::Key, colors[locked]);
    g.place_agent_in(Some((l, 0)), Some((r - l, h)))?;
    let (lc, kc) = (colors[locked], colors[key_room]);
    Ok(Made {
        mission: format!(
            "get the {lc} key from the {kc} room, unlock the {lc} door and go to the goal"
        ),
        rules: Rules::Plain,
        instr: to_goal(),
    })
}

/// `PlaygroundEnv._gen_grid`: 3 × 3 rooms joined by doors of random colours and twelve
/// random objects; no mission, no reward.
pub fn playground(g: &mut Gen) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.horz_wall(0, 0, None, ObjectKind::Wall);
    g.horz_wall(0, h - 1, None, ObjectKind::Wall);
    g.vert_wall(0, 0, None, ObjectKind::Wall);
    g.vert_wall(w - 1, 0, None, ObjectKind::Wall);
    let (room_w, room_h) = (w / 3, h / 3);
    for j in 0..3 {
        for i in 0..3 {
            let (xl, yt) = (i * room_w, j * room_h);
            let (xr, yb) = (xl + room_w, yt + room_h);
            if i + 1 < 3 {
                g.vert_wall(xr, yt, Some(room_h), ObjectKind::Wall);
                let pos = (xr, g.rand_int(yt + 1, yb - 1));
                let color = g.rand_elem(&COLOR_NAMES);
                g.put_door(pos, color, false);
            }
            if j + 1 < 3 {
                g.horz_wall(xl, yb, Some(room_w), ObjectKind::Wall);
                let pos = (g.rand_int(xl + 1, xr - 1), yb);
                let color = g.rand_elem(&COLOR_NAMES);
                g.put_door(pos, color, false);
            }
        }
    }
    g.place_agent_in(None, None)?;
    for _ in 0..12 {
        let kind = g.rand_elem(&DISTRACTOR_TYPES);
        let color = g.rand_elem(&COLOR_NAMES);
        let obj = g.obj(kind, color);
        g.place_anywhere(obj)?;
    }
    Ok(Made {
        mission: String::new(),
        rules: Rules::Plain,
        instr: to_goal(),
    })
}

/// `RedBlueDoorEnv._gen_grid`: a room with a red door on its left wall and a blue one on its
/// right, inside a grid twice as wide.
pub fn red_blue_doors(g: &mut Gen) -> Result<Made, Retry> {
    let size = g.grid.height() as i32;
    g.wall_rect(0, 0, 2 * size, size);
    g.wall_rect(size / 2, 0, size, size);
    g.place_agent_in(Some((size / 2, 0)), Some((size, size)))?;
    let red = (size / 2, g.rand_int(1, size - 1));
    g.put_door(red, Color::Red, false);
    let blue = (size / 2 + size - 1, g.rand_int(1, size - 1));
    g.put_door(blue, Color::Blue, false);
    Ok(Made {
        mission: "open the red door then the blue door".to_owned(),
        rules: Rules::RedBlueDoors { red, blue },
        instr: Instr::seq(
            SeqKind::Before,
            clause(TaskKind::Open, ObjectKind::Door, Color::Red),
            clause(TaskKind::Open, ObjectKind::Door, Color::Blue),
        ),
    })
}

/// `MemoryEnv._gen_grid`: an object in the start room, a hallway, and two objects at its end,
/// one of the start object's type.
pub fn memory(g: &mut Gen, random_length: bool) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.horz_wall(0, 0, None, ObjectKind::Wall);
    g.horz_wall(0, h - 1, None, ObjectKind::Wall);
    g.vert_wall(0, 0, None, ObjectKind::Wall);
    g.vert_wall(w - 1, 0, None, ObjectKind::Wall);
    let (upper, lower) = (h / 2 - 2, h / 2 + 2);
    let end = if random_length {
        g.rand_int(4, w - 2)
    } else {
        w - 3
    };
    let wall = |g: &mut Gen, p: Pos| {
        g.put(p, ObjectKind::Wall, Color::Grey);
    };
    for i in 1..5 {
        wall(g, (i, upper));
        wall(g, (i, lower));
    }
    wall(g, (4, upper + 1));
    wall(g, (4, lower - 1));
    for i in 5..end {
        wall(g, (i, upper + 1));
        wall(g, (i, lower - 1));
    }
    for j in 0..h {
        if j != h / 2 {
            wall(g, (end, j));
        }
        wall(g, (end + 2, j));
    }
    g.agent_pos = (g.rand_int(1, end + 1), h / 2);
    g.agent_dir = 0;
    let kinds = [ObjectKind::Key, ObjectKind::Ball];
    let start = g.rand_elem(&kinds);
    g.put((1, h / 2 - 1), start, Color::Green);
    let orders = [
        [ObjectKind::Ball, ObjectKind::Key],
        [ObjectKind::Key, ObjectKind::Ball],
    ];
    let other = orders[g.rng.below(0, 2)];
    let (pos0, pos1) = ((end + 1, h / 2 - 2), (end + 1, h / 2 + 2));
    g.put(pos0, other[0], Color::Green);
    g.put(pos1, other[1], Color::Green);
    let (success, failure) = if start == other[0] {
        ((pos0.0, pos0.1 + 1), (pos1.0, pos1.1 - 1))
    } else {
        ((pos1.0, pos1.1 - 1), (pos0.0, pos0.1 + 1))
    };
    Ok(Made {
        mission: "go to the matching object at the end of the hallway".to_owned(),
        rules: Rules::Memory { success, failure },
        instr: clause(TaskKind::GoTo, start, Color::Green),
    })
}
