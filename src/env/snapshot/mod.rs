//! World snapshots in the JSON format of `shared/tools/dump_minigrid.py`, and replay checks.
//!
//! A snapshot holds everything a world needs: the x-major grid encoding (`grid[x][y] =
//! [type, colour, state]`, the agent not in it), the agent pose, the carried object, the
//! instruction (kind, type, colour, location, matching positions), `done_actions` and
//! `max_steps`. Dumps from Python also carry `steps`, which [`verify_dump`] replays.

mod instr_json;
mod json_path;
mod minigrid;
mod verify;

use instr_json::override_targets;
pub use instr_json::{instr_from_json, instr_to_json};

pub use verify::{MINIGRID_VERSION, Mismatch, verify_dump, verify_generation};

use serde::{Deserialize, Serialize};

use super::error::EnvError;
use super::grid::{Grid, Pos, Rooms};
use super::object::{Cell, Color, DoorState, ObjectKind, WorldObj};
use super::view::Observation;
use super::world::World;

/// An object description of a dump, with the positions it matched.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DescJson {
    /// Object type name or null ("object").
    #[serde(rename = "type", default)]
    pub kind_name: Option<String>,
    /// Colour name or null.
    #[serde(default)]
    pub color: Option<String>,
    /// Location name or null.
    #[serde(default)]
    pub loc: Option<String>,
    /// Positions of the matching objects, `[x, y]`.
    #[serde(default)]
    pub match_positions: Vec<[i64; 2]>,
}

/// `instr` of a dump: a tree. GoTo / Pickup / Open carry one description inline; PutNext
/// `move` and `fixed`; And / Before / After `a` and `b`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstrJson {
    /// `"GoToInstr"`, `"PickupInstr"`, `"OpenInstr"`, `"PutNextInstr"`, `"AndInstr"`,
    /// `"BeforeInstr"` or `"AfterInstr"`.
    pub kind: String,
    /// Object type name or null (one-description clauses).
    #[serde(rename = "type", default, skip_serializing_if = "Option::is_none")]
    pub kind_name: Option<String>,
    /// Colour name or null.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<String>,
    /// Location name or null.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loc: Option<String>,
    /// Positions of the matching objects, `[x, y]`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub match_positions: Vec<[i64; 2]>,
    /// BabyAI's `strict`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strict: Option<bool>,
    /// PutNext: the object to move.
    #[serde(rename = "move", default, skip_serializing_if = "Option::is_none")]
    pub moved: Option<DescJson>,
    /// PutNext: the object to put it next to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fixed: Option<DescJson>,
    /// A sequence's first part.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub a: Option<Box<InstrJson>>,
    /// A sequence's second part.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b: Option<Box<InstrJson>>,
}

/// What a box holds: `[x, y, [type, colour, state]]`.
pub type BoxJson = (i64, i64, [i64; 3]);

/// An observation as dumped.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObsJson {
    /// x-major 7×7×3 image.
    pub image: Vec<Vec<Vec<i64>>>,
    /// Agent direction.
    pub direction: i64,
    /// Mission text.
    pub mission: String,
}

/// One dumped step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepJson {
    /// Action index.
    pub action: i64,
    /// Action name.
    #[serde(default)]
    pub action_name: Option<String>,
    /// Reward returned.
    pub reward: f64,
    /// Terminated flag.
    pub terminated: bool,
    /// Truncated flag.
    pub truncated: bool,
    /// `step_count` after the step.
    pub step_count: i64,
    /// Agent position after the step.
    pub agent_pos: [i64; 2],
    /// Agent direction after the step.
    pub agent_dir: i64,
    /// Carried object encoding after the step.
    pub carrying: Option<[i64; 3]>,
    /// Observation image after the step.
    pub image: Vec<Vec<Vec<i64>>>,
    /// Observation direction.
    pub direction: i64,
    /// The world grid, present only when the step changed it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<Vec<Vec<Vec<i64>>>>,
    /// What each box holds, present only when the step changed the grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub box_contents: Option<Vec<BoxJson>>,
    /// minigrid's bot's suggestion before this step (`gen_minigrid_fixtures.py
    /// --record-bot`): an action index, or null once it gave up; absent in other dumps.
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    pub bot_action: Option<serde_json::Value>,
    /// The bot's subgoal stack after that replan, bottom first (`--record-bot`; null once it
    /// gave up); absent in other dumps.
    #[serde(
        default,
        deserialize_with = "present",
        skip_serializing_if = "Option::is_none"
    )]
    pub bot_stack: Option<serde_json::Value>,
}

/// A field that is present, even as `null` (absent: `None` through `default`).
fn present<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<serde_json::Value>, D::Error> {
    serde_json::Value::deserialize(d).map(Some)
}

/// A world snapshot / episode dump (the `dump_minigrid.py` format).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Snapshot {
    /// Producer version (`minigrid` version for Python dumps).
    #[serde(default)]
    pub minigrid_version: Option<String>,
    /// Level id.
    #[serde(default)]
    pub env_id: Option<String>,
    /// Level seed.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Grid width.
    pub width: i64,
    /// Grid height.
    pub height: i64,
    /// Room size.
    #[serde(default)]
    pub room_size: Option<i64>,
    /// View size (must be 7).
    #[serde(default)]
    pub agent_view_size: Option<i64>,
    /// Must be false.
    #[serde(default)]
    pub see_through_walls: Option<bool>,
    /// BabyAI's done-action mode.
    pub done_actions: bool,
    /// Truncation horizon.
    pub max_steps: i64,
    /// Mission text.
    pub mission: String,
    /// The instruction; `null` for MiniGrid's own environments (their state beyond the grid,
    /// their step rules, comes from `env_id` and `seed`).
    #[serde(default)]
    pub instr: Option<InstrJson>,
    /// Free-text note on the layout.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout_note: Option<String>,
    /// Grid encoding, `grid[x][y] = [type, colour, state]`.
    pub grid: Vec<Vec<Vec<i64>>>,
    /// What each box holds (the grid encoding does not show it).
    #[serde(default)]
    pub box_contents: Vec<BoxJson>,
    /// MiniGrid's `pprint_grid` lines.
    #[serde(default)]
    pub grid_ascii: Vec<String>,
    /// Agent position.
    pub agent_pos: [i64; 2],
    /// Agent direction.
    pub agent_dir: i64,
    /// Carried object encoding.
    pub carrying: Option<[i64; 3]>,
    /// Steps taken so far.
    #[serde(default)]
    pub step_count: i64,
    /// The observation of this state.
    #[serde(default)]
    pub initial_obs: Option<ObsJson>,
    /// Dumped steps from this state, if any.
    #[serde(default)]
    pub steps: Vec<StepJson>,
}

fn invalid(field: impl Into<String>, reason: impl Into<String>) -> EnvError {
    EnvError::InvalidSnapshot {
        field: field.into(),
        reason: reason.into(),
    }
}

fn u8_in(v: i64, max: u8, field: impl Fn() -> String) -> Result<u8, EnvError> {
    u8::try_from(v)
        .ok()
        .filter(|x| *x <= max)
        .ok_or_else(|| invalid(field(), format!("{v} is out of range 0..={max}")))
}

/// Decodes one `[type, colour, state]` triple (MiniGrid's `WorldObj.decode`).
fn decode_cell(v: &[i64], id: u32, field: &str) -> Result<Cell, EnvError> {
    let [t, c, s] = v else {
        return Err(invalid(
            field,
            format!("expected [type, colour, state], got {} values", v.len()),
        ));
    };
    let kind = ObjectKind::from_index(u8_in(*t, 10, || format!("{field}[0]"))?)
        .ok_or_else(|| invalid(field, "unknown type"))?;
    let color = Color::from_index(u8_in(*c, 5, || format!("{field}[1]"))?)
        .ok_or_else(|| invalid(field, "unknown colour"))?;
    let state = u8_in(*s, 2, || format!("{field}[2]"))?;
    match kind {
        ObjectKind::Empty => Ok(None),
        ObjectKind::Unseen => Err(invalid(
            field,
            "type 0 (unseen) only appears in observations, not in a world grid",
        )),
        ObjectKind::Agent => Err(invalid(field, "the agent is not stored in the grid")),
        ObjectKind::Door => {
            let state = [DoorState::Open, DoorState::Closed, DoorState::Locked][usize::from(state)];
            Ok(Some(WorldObj {
                kind,
                color,
                state,
                id,
            }))
        }
        _ if state != 0 => Err(invalid(
            format!("{field}[2]"),
            format!("state {state} is only valid for doors"),
        )),
        _ => Ok(Some(WorldObj::new(kind, color, id))),
    }
}

fn encode_i64(enc: [u8; 3]) -> Vec<i64> {
    enc.iter().map(|&v| i64::from(v)).collect()
}

/// The grid of a dump, with ids in x-major order starting at 0.
pub fn decode_grid(
    rows: &[Vec<Vec<i64>>],
    width: i64,
    height: i64,
    field: &str,
) -> Result<Grid, EnvError> {
    if rows.len() as i64 != width {
        return Err(invalid(
            field,
            format!("{} columns, but width is {width}", rows.len()),
        ));
    }
    let mut grid = Grid::new(width as usize, height as usize);
    let mut id = 0;
    for (x, col) in rows.iter().enumerate() {
        if col.len() as i64 != height {
            return Err(invalid(
                format!("{field}[{x}]"),
                format!("{} cells, but height is {height}", col.len()),
            ));
        }
        for (y, v) in col.iter().enumerate() {
            let cell = decode_cell(v, id, &format!("{field}[{x}][{y}]"))?;
            if cell.is_some() {
                id += 1;
            }
            grid.set((x as i32, y as i32), cell);
        }
    }
    Ok(grid)
}

/// MiniGrid's `pprint_grid`: two characters per cell, rows top to bottom.
pub fn ascii_grid(grid: &Grid, agent_pos: Pos, agent_dir: u8) -> Vec<String> {
    let mut lines = Vec::with_capacity(grid.height());
    for y in 0..grid.height() as i32 {
        let mut line = String::with_capacity(grid.width() * 2);
        for x in 0..grid.width() as i32 {
            if (x, y) == agent_pos {
                let c = ['>', 'V', '<', '^'][usize::from(agent_dir & 3)];
                line.push(c);
                line.push(c);
                continue;
            }
            let Some(o) = grid.get((x, y)) else {
                line.push_str("  ");
                continue;
            };
            let color = o
                .color
                .name()
                .chars()
                .next()
                .unwrap_or(' ')
                .to_ascii_uppercase();
            let kind = match o.kind {
                ObjectKind::Door => match o.state {
                    DoorState::Open => {
                        line.push_str("__");
                        continue;
                    }
                    DoorState::Locked => 'L',
                    DoorState::Closed => 'D',
                },
                ObjectKind::Wall => 'W',
                ObjectKind::Floor => 'F',
                ObjectKind::Key => 'K',
                ObjectKind::Ball => 'A',
                ObjectKind::Box => 'B',
                ObjectKind::Goal => 'G',
                ObjectKind::Lava => 'V',
                ObjectKind::Unseen | ObjectKind::Empty | ObjectKind::Agent => '?',
            };
            line.push(kind);
            line.push(color);
        }
        lines.push(line);
    }
    lines
}

fn pos_of(v: [i64; 2], field: &str) -> Result<Pos, EnvError> {
    let ok = |x: i64| i32::try_from(x).map_err(|_| invalid(field, format!("{x} is out of range")));
    Ok((ok(v[0])?, ok(v[1])?))
}

impl Snapshot {
    /// Parses a snapshot from JSON text; an error names the field by its path
    /// (`steps[3].action: missing (a required field)`), or the line and column of bad JSON.
    pub fn from_json(text: &str) -> Result<Self, EnvError> {
        serde_json::from_str(text).map_err(|e| {
            let (field, reason) = json_path::field_of(text, &e);
            invalid(field, reason)
        })
    }

    /// Serialises the snapshot as pretty JSON.
    pub fn to_json(&self) -> String {
        // Serialising plain data with string keys cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Rebuilds the world this snapshot describes (at its `step_count`).
    pub fn to_world(&self) -> Result<World, EnvError> {
        if !(1..=256).contains(&self.width) || !(1..=256).contains(&self.height) {
            return Err(invalid(
                "width",
                format!("{}×{} is not a grid size", self.width, self.height),
            ));
        }
        if let Some(v) = self.agent_view_size
            && v != 7
        {
            return Err(invalid(
                "agent_view_size",
                format!("{v} is not supported (only 7)"),
            ));
        }
        let Some(instr) = &self.instr else {
            return self.minigrid_world();
        };
        if self.see_through_walls == Some(true) {
            return Err(invalid(
                "see_through_walls",
                "true is only supported on MiniGrid's own environments (instr null)",
            ));
        }
        let grid = decode_grid(&self.grid, self.width, self.height, "grid")?;
        let mut next_id = grid.objects().count() as u32;
        let agent_pos = pos_of(self.agent_pos, "agent_pos")?;
        let agent_dir = u8_in(self.agent_dir, 3, || "agent_dir".into())?;
        let carrying = match &self.carrying {
            None => None,
            Some(c) => {
                let obj = decode_cell(c, next_id, "carrying")?;
                next_id += 1;
                match obj {
                    Some(o) if o.kind.can_pickup() => Some(o),
                    _ => {
                        return Err(invalid(
                            "carrying",
                            "only keys, balls and boxes can be carried",
                        ));
                    }
                }
            }
        };
        let mut box_contents = Vec::with_capacity(self.box_contents.len());
        for (i, (x, y, inner)) in self.box_contents.iter().enumerate() {
            let field = format!("box_contents[{i}]");
            let pos = pos_of([*x, *y], &field)?;
            let Some(bx) = grid.get(pos).filter(|o| o.kind == ObjectKind::Box) else {
                return Err(invalid(field, format!("{pos:?} holds no box")));
            };
            let Some(obj) = decode_cell(inner, next_id, &format!("{field}[2]"))? else {
                return Err(invalid(field, "a box holds an object, not an empty cell"));
            };
            next_id += 1;
            box_contents.push((bx.id, obj));
        }
        let rooms = self.rooms();
        let tree = instr_from_json(instr, "instr")?;
        let max_steps = u32::try_from(self.max_steps)
            .map_err(|_| invalid("max_steps", format!("{} is out of range", self.max_steps)))?;
        // A PutNext "Carrying" dump at reset: the carried object's match position is empty.
        // The verifier was reset with the object still there: put it back for the reset and
        // lift it again after.
        let floor = match (&instr.moved, carrying) {
            (Some(m), Some(_)) if self.step_count == 0 => m
                .match_positions
                .iter()
                .filter_map(|p| pos_of(*p, "instr.move.match_positions").ok())
                .find(|p| grid.contains(*p) && grid.get(*p).is_none()),
            _ => None,
        };
        let mut grid = grid;
        if let Some(p) = floor {
            grid.set(p, carrying);
        }
        let mut world = World::with_tree(
            grid,
            rooms,
            agent_pos,
            agent_dir,
            if floor.is_some() { None } else { carrying },
            tree,
            max_steps,
            self.done_actions,
            next_id,
        )?;
        if let Some(p) = floor {
            world.grid.set(p, None);
            world.carrying = carrying;
            world.reset_floor = Some(p);
        }
        world.box_contents = box_contents;
        override_targets(&mut world, instr)?;
        world.mission = world.instr.surface();
        world.step_count = u32::try_from(self.step_count)
            .ok()
            .filter(|s| *s < max_steps)
            .ok_or_else(|| {
                invalid(
                    "step_count",
                    format!("{} is not below max_steps", self.step_count),
                )
            })?;
        if world.mission != self.mission {
            return Err(invalid(
                "mission",
                format!(
                    "{:?} does not match the instruction, which reads {:?}",
                    self.mission, world.mission
                ),
            ));
        }
        Ok(world)
    }

    /// The rooms of the dump: `room_size` splits the grid when it tiles it, else one room.
    /// The rooms the snapshot's size and `room_size` describe.
    pub fn rooms(&self) -> Rooms {
        let (w, h) = (self.width, self.height);
        match self.room_size {
            Some(rs) if rs >= 3 && (w - 1) % (rs - 1) == 0 && (h - 1) % (rs - 1) == 0 => Rooms {
                room_size: rs as i32,
                num_cols: ((w - 1) / (rs - 1)) as i32,
                num_rows: ((h - 1) / (rs - 1)) as i32,
            },
            _ => Rooms::single(w as usize, h as usize),
        }
    }

    /// The snapshot of `world` (no steps), with its observation as `initial_obs`.
    pub fn from_world(world: &World, env_id: Option<String>, seed: Option<u64>) -> Self {
        let grid = world
            .grid
            .encode()
            .into_iter()
            .map(|col| col.into_iter().map(encode_i64).collect())
            .collect();
        let obs = world.observe();
        let carrying = world.carrying.map(|c| {
            let e = c.encode();
            [i64::from(e[0]), i64::from(e[1]), i64::from(e[2])]
        });
        Self {
            minigrid_version: Some(format!(
                "{}{}",
                verify::PRODUCER_PREFIX,
                env!("CARGO_PKG_VERSION")
            )),
            env_id,
            seed,
            width: world.grid.width() as i64,
            height: world.grid.height() as i64,
            room_size: Some(i64::from(world.rooms.room_size)),
            agent_view_size: Some(7),
            see_through_walls: Some(world.see_through_walls),
            done_actions: world.done_actions,
            max_steps: i64::from(world.max_steps),
            mission: world.mission.clone(),
            instr: world.rules.is_none().then(|| instr_to_json(&world.instr)),
            layout_note: None,
            grid,
            box_contents: box_contents_json(world),
            grid_ascii: ascii_grid(&world.grid, world.agent_pos, world.agent_dir),
            agent_pos: [i64::from(world.agent_pos.0), i64::from(world.agent_pos.1)],
            agent_dir: i64::from(world.agent_dir),
            carrying,
            step_count: i64::from(world.step_count),
            initial_obs: Some(ObsJson {
                image: obs_to_i64(&obs),
                direction: i64::from(world.agent_dir),
                mission: world.mission.clone(),
            }),
            steps: Vec::new(),
        }
    }
}

fn obs_to_i64(obs: &Observation) -> Vec<Vec<Vec<i64>>> {
    obs.image
        .iter()
        .map(|col| col.iter().map(|&c| encode_i64(c)).collect())
        .collect()
}

/// The dump's `box_contents` of a world: `[x, y, inner]` for every box on the grid that holds
/// something, x outer.
pub(crate) fn box_contents_json(world: &World) -> Vec<BoxJson> {
    let mut out = Vec::new();
    for (pos, obj) in world.grid.objects() {
        if obj.kind != ObjectKind::Box {
            continue;
        }
        if let Some((_, inner)) = world.box_contents.iter().find(|(b, _)| *b == obj.id) {
            let e = inner.encode();
            out.push((
                i64::from(pos.0),
                i64::from(pos.1),
                [i64::from(e[0]), i64::from(e[1]), i64::from(e[2])],
            ));
        }
    }
    out
}
