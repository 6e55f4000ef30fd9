//! MiniGrid's RoomGrid environments: KeyCorridor, Unlock, UnlockPickup, BlockedUnlockPickup
//! and ObstructedMaze v0 and v1 (`minigrid/envs/{keycorridor,unlock,unlockpickup,
//! blockedunlockpickup,obstructedmaze,obstructedmaze_v1}.py`). Their generation is RoomGrid's,
//! without BabyAI's retry loop: an attempt that fails is an error, as minigrid raises.

use super::{Made, Rules, clause};
use crate::env::babyai::roomgrid::{COLOR_NAMES, Gen, Retry};
use crate::env::grid::{DIR_TO_VEC, Pos};
use crate::env::mission::TaskKind;
use crate::env::object::{Color, ObjectKind, WorldObj};

fn pick_up(obj: WorldObj) -> Made {
    Made {
        mission: format!("pick up the {} {}", obj.color, obj.kind),
        rules: Rules::Pickup { target: obj.id },
        instr: clause(TaskKind::Pickup, obj.kind, obj.color),
    }
}

/// `KeyCorridorEnv._gen_grid`: a corridor of rooms, the object behind a locked door on the
/// right, its key in a room on the left.
pub fn key_corridor(g: &mut Gen, obj_kind: ObjectKind) -> Result<Made, Retry> {
    let rows = g.rooms.num_rows;
    for j in 1..rows {
        g.remove_wall(1, j, 3);
    }
    let room_idx = g.rand_int(0, rows);
    let (door, _) = g.add_door(2, room_idx, Some(2), None, Some(true));
    let (obj, _) = g.add_object(2, room_idx, Some(obj_kind), None)?;
    let key_row = g.rand_int(0, rows);
    g.add_object(0, key_row, Some(ObjectKind::Key), Some(door.color))?;
    g.place_agent(Some(1), Some(rows / 2))?;
    g.connect_all(&COLOR_NAMES)?;
    Ok(pick_up(obj))
}

/// `UnlockEnv._gen_grid`: a locked door on the first room's right, its key beside the agent.
pub fn unlock(g: &mut Gen) -> Result<Made, Retry> {
    let (door, pos) = g.add_door(0, 0, Some(0), None, Some(true));
    g.add_object(0, 0, Some(ObjectKind::Key), Some(door.color))?;
    g.place_agent(Some(0), Some(0))?;
    Ok(Made {
        mission: "open the door".to_owned(),
        rules: Rules::Unlock { door: pos },
        instr: clause(TaskKind::Open, ObjectKind::Door, door.color),
    })
}

/// `UnlockPickupEnv._gen_grid` and, with `blocked`, `BlockedUnlockPickupEnv._gen_grid` (a
/// ball of a random colour in front of the door).
pub fn unlock_pickup(g: &mut Gen, blocked: bool) -> Result<Made, Retry> {
    let (obj, _) = g.add_object(1, 0, Some(ObjectKind::Box), None)?;
    let (door, pos) = g.add_door(0, 0, Some(0), None, Some(true));
    if blocked {
        let color = g.rand_color();
        let ball = g.obj(ObjectKind::Ball, color);
        g.grid.set((pos.0 - 1, pos.1), Some(ball));
    }
    g.add_object(0, 0, Some(ObjectKind::Key), Some(door.color))?;
    g.place_agent(Some(0), Some(0))?;
    Ok(pick_up(obj))
}

/// ObstructedMaze's colours: `COLOR_NAMES[0]` (blue) for the ball to find, `[1]` (green) for
/// the blocking balls, `[2]` (grey) for the boxes.
const BALL_TO_FIND: Color = COLOR_NAMES[0];
const BLOCKING: Color = COLOR_NAMES[1];
const BOX: Color = COLOR_NAMES[2];

/// `ObstructedMazeEnv.add_door`: the door, a blocking ball before it when `blocked`, and when
/// `locked` its key (in a box when `key_in_box`) placed in room `(i, j)` at once.
fn add_door(
    g: &mut Gen,
    (i, j): (i32, i32),
    door_idx: usize,
    color: Color,
    locked: bool,
    (key_in_box, blocked): (bool, bool),
) -> Result<(), Retry> {
    let (door, _) = add_locked_door(g, (i, j), door_idx, color, locked, blocked);
    if locked {
        add_key(g, (i, j), door.color, key_in_box)?;
    }
    Ok(())
}

/// `RoomGrid.add_door`, then the blocking ball (`ObstructedMaze_Full_V1.add_locked_door`).
fn add_locked_door(
    g: &mut Gen,
    (i, j): (i32, i32),
    door_idx: usize,
    color: Color,
    locked: bool,
    blocked: bool,
) -> (WorldObj, Pos) {
    let (door, pos) = g.add_door(i, j, Some(door_idx), Some(color), Some(locked));
    if blocked {
        let v = DIR_TO_VEC[door_idx];
        let ball = g.obj(ObjectKind::Ball, BLOCKING);
        g.grid.set((pos.0 - v.0, pos.1 - v.1), Some(ball));
    }
    (door, pos)
}

/// The key of a locked door, in a box that holds it when `key_in_box`
/// (`ObstructedMaze_Full_V1.add_key`).
fn add_key(g: &mut Gen, (i, j): (i32, i32), color: Color, key_in_box: bool) -> Result<(), Retry> {
    let key = g.obj(ObjectKind::Key, color);
    let placed = if key_in_box {
        let bx = g.obj(ObjectKind::Box, BOX);
        g.box_contents.push((bx.id, key));
        bx
    } else {
        key
    };
    g.place_in_room(i, j, placed)?;
    Ok(())
}

/// `ObstructedMaze_1Dlhb._gen_grid` (1Dl, 1Dlh, 1Dlhb): one locked door between two rooms.
pub fn obstructed_1(g: &mut Gen, key_in_box: bool, blocked: bool) -> Result<Made, Retry> {
    let colors = g.rand_subset(&COLOR_NAMES, COLOR_NAMES.len());
    add_door(g, (0, 0), 0, colors[0], true, (key_in_box, blocked))?;
    let (obj, _) = g.add_object(1, 0, Some(ObjectKind::Ball), Some(BALL_TO_FIND))?;
    g.place_agent(Some(0), Some(0))?;
    Ok(pick_up(obj))
}

/// `ObstructedMaze_Full._gen_grid` (and the 2Dl… / 1Q / 2Q presets), or with `v1`
/// `ObstructedMaze_Full_V1._gen_grid`: per quarter an open door of the middle room and two
/// locked doors of the side room — v0 places each door's key right after it, v1 both doors
/// and then both keys — then the blue ball in a random corner room.
pub fn obstructed_full(
    g: &mut Gen,
    v1: bool,
    agent_room: (i32, i32),
    (key_in_box, blocked): (bool, bool),
    num_quarters: usize,
) -> Result<Made, Retry> {
    let colors = g.rand_subset(&COLOR_NAMES, COLOR_NAMES.len());
    let middle = (1, 1);
    let side_rooms = [(2, 1), (1, 2), (0, 1), (1, 0)];
    for (i, &side) in side_rooms.iter().take(num_quarters).enumerate() {
        add_door(g, middle, i, colors[i], false, (false, false))?;
        // Python's `(i + k) % 4` and `(i + k) % len(door_colors)` for k = -1, 1.
        let around: Vec<(usize, Color)> = [-1i32, 1]
            .iter()
            .map(|k| {
                let n = i as i32 + k;
                let c = colors[n.rem_euclid(colors.len() as i32) as usize];
                (n.rem_euclid(4) as usize, c)
            })
            .collect();
        if v1 {
            for &(k, c) in &around {
                add_locked_door(g, side, k, c, true, blocked);
            }
            for &(_, c) in &around {
                add_key(g, side, c, key_in_box)?;
            }
        } else {
            for &(k, c) in &around {
                add_door(g, side, k, c, true, (key_in_box, blocked))?;
            }
        }
    }
    let corners = [(2, 0), (2, 2), (0, 2), (0, 0)];
    let room = corners[g.rng.below(0, num_quarters.min(corners.len()))];
    let (obj, _) = g.add_object(room.0, room.1, Some(ObjectKind::Ball), Some(BALL_TO_FIND))?;
    g.place_agent(Some(agent_room.0), Some(agent_room.1))?;
    Ok(pick_up(obj))
}
