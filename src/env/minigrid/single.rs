//! One-room layouts: Empty, DoorKey, FourRooms, LavaGap, DistShift, Crossing and
//! Dynamic-Obstacles (`minigrid/envs/{empty,doorkey,fourrooms,lavagap,distshift,crossing,
//! dynamicobstacles}.py`).

use super::{INF_TRIES, Made, Rules, to_goal};
use crate::env::babyai::roomgrid::{Gen, Retry};
use crate::env::grid::Pos;
use crate::env::object::{Color, ObjectKind};

const GOAL_MISSION: &str = "get to the green goal square";

fn plain(mission: &str) -> Made {
    Made {
        mission: mission.to_owned(),
        rules: Rules::Plain,
        instr: to_goal(),
    }
}

/// The agent at a fixed pose, or `place_agent()` anywhere.
fn start(g: &mut Gen, at: Option<(Pos, u8)>) -> Result<(), Retry> {
    match at {
        Some((pos, dir)) => {
            g.agent_pos = pos;
            g.agent_dir = dir;
        }
        None => {
            g.place_agent_in(None, None)?;
        }
    }
    Ok(())
}

/// `EmptyEnv._gen_grid`.
pub fn empty(g: &mut Gen, at: Option<(Pos, u8)>) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.wall_rect(0, 0, w, h);
    g.put((w - 2, h - 2), ObjectKind::Goal, Color::Green);
    start(g, at)?;
    Ok(plain(GOAL_MISSION))
}

/// `DoorKeyEnv._gen_grid`: a wall column, the agent left of it, a locked yellow door in it
/// and the yellow key on the agent's side.
pub fn door_key(g: &mut Gen) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.wall_rect(0, 0, w, h);
    g.put((w - 2, h - 2), ObjectKind::Goal, Color::Green);
    let split = g.rand_int(2, w - 2);
    g.vert_wall(split, 0, None, ObjectKind::Wall);
    g.place_agent_in(None, Some((split, h)))?;
    let door_y = g.rand_int(1, h - 2);
    g.put_door((split, door_y), Color::Yellow, true);
    let key = g.obj(ObjectKind::Key, Color::Yellow);
    g.place_obj(Some(key), (0, 0), (split, h), false, INF_TRIES)?;
    Ok(plain(
        "use the key to open the door and then get to the goal",
    ))
}

/// `FourRoomsEnv._gen_grid`: four rooms of a 19 × 19 grid, one gap in each inner wall.
pub fn four_rooms(g: &mut Gen, agent: Option<Pos>, goal: Option<Pos>) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    let wall = ObjectKind::Wall;
    g.horz_wall(0, 0, None, wall);
    g.horz_wall(0, h - 1, None, wall);
    g.vert_wall(0, 0, None, wall);
    g.vert_wall(w - 1, 0, None, wall);
    let (room_w, room_h) = (w / 2, h / 2);
    for j in 0..2 {
        for i in 0..2 {
            let (xl, yt) = (i * room_w, j * room_h);
            let (xr, yb) = (xl + room_w, yt + room_h);
            if i + 1 < 2 {
                g.vert_wall(xr, yt, Some(room_h), wall);
                let y = g.rand_int(yt + 1, yb);
                g.grid.set((xr, y), None);
            }
            if j + 1 < 2 {
                g.horz_wall(xl, yb, Some(room_w), wall);
                let x = g.rand_int(xl + 1, xr);
                g.grid.set((x, yb), None);
            }
        }
    }
    match agent {
        Some(pos) => {
            g.agent_pos = pos;
            g.grid.set(pos, None);
            g.agent_dir = g.rand_int(0, 4) as u8;
        }
        None => {
            g.place_agent_in(None, None)?;
        }
    }
    let goal_obj = g.obj(ObjectKind::Goal, Color::Green);
    match goal {
        Some(pos) => g.grid.set(pos, Some(goal_obj)),
        None => {
            g.place_anywhere(goal_obj)?;
        }
    }
    Ok(plain("reach the goal"))
}

/// `LavaGapEnv._gen_grid`: a column of lava (or wall) with one gap.
pub fn lava_gap(g: &mut Gen, lava: bool) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.wall_rect(0, 0, w, h);
    g.agent_pos = (1, 1);
    g.agent_dir = 0;
    g.put((w - 2, h - 2), ObjectKind::Goal, Color::Green);
    let gap = (g.rand_int(2, w - 2), g.rand_int(1, h - 1));
    let kind = if lava {
        ObjectKind::Lava
    } else {
        ObjectKind::Wall
    };
    g.vert_wall(gap.0, 1, Some(h - 2), kind);
    g.grid.set(gap, None);
    Ok(plain(if lava {
        "avoid the lava and get to the green goal square"
    } else {
        "find the opening and get to the green goal square"
    }))
}

/// `DistShiftEnv._gen_grid`: two strips of lava, the goal top right.
pub fn dist_shift(g: &mut Gen, at: Option<(Pos, u8)>, strip2_row: i32) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.wall_rect(0, 0, w, h);
    g.put((w - 2, 1), ObjectKind::Goal, Color::Green);
    for i in 0..(w - 6).max(0) {
        g.put((3 + i, 1), ObjectKind::Lava, Color::Red);
        g.put((3 + i, strip2_row), ObjectKind::Lava, Color::Red);
    }
    start(g, at)?;
    Ok(plain(GOAL_MISSION))
}

/// `CrossingEnv._gen_grid`: rivers of lava (or wall) across the room, shuffled with numpy's
/// `shuffle`, and one crossing per river along a shuffled path.
pub fn crossing(g: &mut Gen, num_crossings: usize, lava: bool) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.wall_rect(0, 0, w, h);
    g.agent_pos = (1, 1);
    g.agent_dir = 0;
    g.put((w - 2, h - 2), ObjectKind::Goal, Color::Green);
    // `(vertical?, index)`: Python's `(v, i)` rivers then `(h, j)` ones.
    let mut rivers: Vec<(bool, i32)> = (2..h - 2).step_by(2).map(|i| (true, i)).collect();
    rivers.extend((2..w - 2).step_by(2).map(|j| (false, j)));
    g.rng.shuffle(&mut rivers);
    rivers.truncate(num_crossings);
    let mut rivers_v: Vec<i32> = rivers.iter().filter(|r| r.0).map(|r| r.1).collect();
    let mut rivers_h: Vec<i32> = rivers.iter().filter(|r| !r.0).map(|r| r.1).collect();
    rivers_v.sort_unstable();
    rivers_h.sort_unstable();
    let kind = if lava {
        ObjectKind::Lava
    } else {
        ObjectKind::Wall
    };
    let color = super::default_color(kind);
    for i in 1..w - 1 {
        for &j in &rivers_h {
            g.put((i, j), kind, color);
        }
    }
    for &i in &rivers_v {
        for j in 1..h - 1 {
            g.put((i, j), kind, color);
        }
    }
    // `true`: a step along `h` (Python's `[h] * len(rivers_v)` first).
    let mut path: Vec<bool> = std::iter::repeat_n(true, rivers_v.len())
        .chain(std::iter::repeat_n(false, rivers_h.len()))
        .collect();
    g.rng.shuffle(&mut path);
    let limits_v: Vec<i32> = std::iter::once(0).chain(rivers_v).chain([h - 1]).collect();
    let limits_h: Vec<i32> = std::iter::once(0).chain(rivers_h).chain([w - 1]).collect();
    let (mut room_i, mut room_j) = (0usize, 0usize);
    for along_h in path {
        let cell = if along_h {
            let i = limits_v[room_i + 1];
            let j = g.rand_int(limits_h[room_j] + 1, limits_h[room_j + 1]);
            room_i += 1;
            (i, j)
        } else {
            let i = g.rand_int(limits_v[room_i] + 1, limits_v[room_i + 1]);
            let j = limits_h[room_j + 1];
            room_j += 1;
            (i, j)
        };
        g.grid.set(cell, None);
    }
    Ok(plain(if lava {
        "avoid the lava and get to the green goal square"
    } else {
        "find the opening and get to the green goal square"
    }))
}

/// `DynamicObstaclesEnv._gen_grid`: the goal bottom right, the agent, then blue balls
/// anywhere (100 tries each).
pub fn dynamic_obstacles(
    g: &mut Gen,
    at: Option<(Pos, u8)>,
    n_obstacles: usize,
) -> Result<Made, Retry> {
    let (w, h) = (g.grid.width() as i32, g.grid.height() as i32);
    g.wall_rect(0, 0, w, h);
    g.put((w - 2, h - 2), ObjectKind::Goal, Color::Green);
    start(g, at)?;
    let mut obstacles = Vec::with_capacity(n_obstacles);
    for _ in 0..n_obstacles {
        let ball = g.obj(ObjectKind::Ball, Color::Blue);
        let pos = g.place_obj(Some(ball), (0, 0), (w, h), false, 100)?;
        obstacles.push((ball.id, pos));
    }
    Ok(Made {
        mission: GOAL_MISSION.to_owned(),
        rules: Rules::DynamicObstacles {
            obstacles,
            rng: g.rng.clone(),
        },
        instr: to_goal(),
    })
}
