//! The paper's level configurations, generated as BabyAI's GoToLocal.
//!
//! `BabyAI-GoToLocalS{S}N{N}-v0` is generated bit for bit ([`crate::env::babyai`]): the agent
//! first, then N distractors (colour then type, duplicates allowed) at Manhattan distance ≥ 2
//! from it, the whole level redrawn when an object is unreachable, the target a uniform pick
//! among them. The paper's level adds two draws after BabyAI's: the task (go to / pick up)
//! when both are configured, and, with `color_optional`, the colour left out when
//! `integers(0, 7) == 0` (the chance BabyAI's `rand_obj` gives `None` among `[None,
//! *COLOR_NAMES]`). docs/world.md gives the Python that generates it in minigrid.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::babyai::{Family, LevelSpec};
use super::error::EnvError;
use super::grid::{Grid, Pos, Rooms};
use super::mission::TaskKind;
use super::world::World;

pub use super::level_id::LevelId;

/// Which task kinds a level draws missions from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TaskSet {
    /// Only "go to …".
    GoTo,
    /// Only "pick up …".
    Pickup,
    /// Both, uniformly.
    Both,
}

impl TaskSet {
    /// The kinds in the set.
    pub fn kinds(self) -> &'static [TaskKind] {
        match self {
            Self::GoTo => &[TaskKind::GoTo],
            Self::Pickup => &[TaskKind::Pickup],
            Self::Both => &[TaskKind::GoTo, TaskKind::Pickup],
        }
    }

    /// Parses `goto`, `pickup` or `both`.
    pub fn parse(s: &str) -> Result<Self, EnvError> {
        match s {
            "goto" | "go-to" => Ok(Self::GoTo),
            "pickup" | "pick-up" => Ok(Self::Pickup),
            "both" => Ok(Self::Both),
            _ => Err(EnvError::InvalidConfig {
                field: "tasks".into(),
                reason: format!("{s:?} is not one of goto, pickup, both"),
            }),
        }
    }
}

/// A level: room size, object count, task kinds and the verification mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelConfig {
    /// Room side S including the walls (interior (S−2)²).
    pub room_size: usize,
    /// Number of objects N.
    pub n_objects: usize,
    /// Task kinds drawn from.
    pub tasks: TaskSet,
    /// BabyAI's done-action mode: the agent must say `done` right after satisfying the task.
    pub done_required: bool,
    /// Descriptions may omit the colour ("go to the ball").
    pub color_optional: bool,
    /// A registered BabyAI level instead of the paper's: then only `done_required` applies
    /// (the other fields describe the paper's level and are ignored).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub babyai: Option<LevelId>,
}

/// The id prefix of the paper's level as docs/world.md registers it in minigrid:
/// `groundscope-PaperLocalS{S}N{N}-v0` (go to and pick up, colour optional, the done action).
pub const PAPER_PREFIX: &str = "groundscope-PaperLocalS";

impl Default for LevelConfig {
    /// The paper's level: S = 8, N = 4, go to and pick up, done required, colour optional.
    fn default() -> Self {
        Self {
            room_size: 8,
            n_objects: 4,
            tasks: TaskSet::Both,
            done_required: true,
            color_optional: true,
            babyai: None,
        }
    }
}

impl fmt::Display for LevelConfig {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(id) = self.babyai {
            let done = if self.done_required {
                " (done-action mode)"
            } else {
                ""
            };
            return write!(f, "{}{done}", id.id());
        }
        let tasks = match self.tasks {
            TaskSet::GoTo => "goto",
            TaskSet::Pickup => "pickup",
            TaskSet::Both => "goto+pickup",
        };
        write!(
            f,
            "S{}N{} {tasks}{}{}",
            self.room_size,
            self.n_objects,
            if self.done_required { " done" } else { "" },
            if self.color_optional {
                " colour-optional"
            } else {
                ""
            }
        )
    }
}

/// Largest room the generator accepts (the view and grids have no limit; this bounds work).
pub const MAX_ROOM_SIZE: usize = 64;

impl LevelConfig {
    /// Whether this is one of MiniGrid's own environments (not a BabyAI level, not the paper's).
    pub fn is_minigrid(&self) -> bool {
        self.babyai.is_some_and(|id| id.minigrid().is_some())
    }

    /// Checks the config, naming the field at fault.
    pub fn validate(&self) -> Result<(), EnvError> {
        if let Some(id) = self.babyai {
            if self.done_required && id.minigrid().is_some() {
                return Err(EnvError::InvalidConfig {
                    field: "done".into(),
                    reason: format!(
                        "{} is one of MiniGrid's own environments, which have no done-action \
                         mode (BabyAI's): `done` is what its own step makes it",
                        id.id()
                    ),
                });
            }
            return Ok(());
        }
        let bad = |field: &str, reason: String| {
            Err(EnvError::InvalidConfig {
                field: field.into(),
                reason,
            })
        };
        if self.room_size < 5 {
            return bad(
                "room_size",
                format!("{} is below the minimum of 5", self.room_size),
            );
        }
        if self.room_size > MAX_ROOM_SIZE {
            return bad(
                "room_size",
                format!("{} is above the maximum of {MAX_ROOM_SIZE}", self.room_size),
            );
        }
        if self.n_objects == 0 {
            return bad("n_objects", "a level needs at least one object".into());
        }
        // Worst case the agent and its 4 neighbours are all interior cells. Dense random
        // layouts wall objects in, and the denser the bigger the room, until the generator's
        // redraws run out; the limit is said here rather than after 10,000 tries. Measured
        // over 20 seeds each: half the rest is always placed up to S9 (S10 failed 9 of 20),
        // a third up to S16 (S12 at a half failed all), a quarter up to S64 (S32 at a third
        // failed all).
        let interior = (self.room_size - 2) * (self.room_size - 2);
        let share = match self.room_size {
            ..=9 => 2,
            10..=16 => 3,
            _ => 4,
        };
        let capacity = (interior.saturating_sub(5) / share).max(1);
        if self.n_objects > capacity {
            return bad(
                "n_objects",
                format!(
                    "{} objects do not fit a room of size {} (at most {capacity}: 1/{share} of \
                     the free interior, so that every object stays reachable)",
                    self.n_objects, self.room_size
                ),
            );
        }
        Ok(())
    }

    /// A registered BabyAI level with the done-action mode `done_required`.
    pub fn babyai(id: LevelId, done_required: bool) -> Self {
        let spec = id.spec();
        Self {
            room_size: spec.rooms.room_size as usize,
            n_objects: 0,
            babyai: Some(id),
            done_required,
            ..Self::default()
        }
    }

    /// The level an id names, in its registered mode: a BabyAI id of minigrid 3.2.0 (no
    /// `done` action), or the paper's `groundscope-PaperLocalS{S}N{N}-v0` (the paper's level
    /// of that size and count). The one parser of level ids; an unknown id names the closest.
    pub fn from_id(id: &str) -> Result<Self, EnvError> {
        match Self::paper_from_id(id) {
            Some(Ok(config)) => Ok(config),
            Some(Err(reason)) => Err(EnvError::InvalidConfig {
                field: "level".into(),
                reason,
            }),
            None => Ok(Self::babyai(LevelId::parse(id)?, false)),
        }
    }

    /// The paper's level named by `id`, `None` for ids without [`PAPER_PREFIX`]; a malformed
    /// or invalid one is `Err` with the reason, for the caller to name its field.
    pub fn paper_from_id(id: &str) -> Option<Result<Self, String>> {
        let rest = id.strip_prefix(PAPER_PREFIX)?;
        let bad = || {
            format!(
                "{} is not {PAPER_PREFIX}{{S}}N{{N}}-v0",
                super::error::shown(id)
            )
        };
        let parsed = rest
            .strip_suffix("-v0")
            .and_then(|body| body.split_once('N'))
            .and_then(|(s, n)| Some((s.parse().ok()?, n.parse().ok()?)));
        let Some((room_size, n_objects)) = parsed else {
            return Some(Err(bad()));
        };
        let config = Self {
            room_size,
            n_objects,
            ..Self::default()
        };
        // The id as registered (no `+8`, no `08`).
        if config.id() != id {
            return Some(Err(bad()));
        }
        Some(config.validate().map(|()| config).map_err(|e| match e {
            EnvError::InvalidConfig { field, reason } => {
                format!("{}: {field}: {reason}", super::error::shown(id))
            }
            e => format!("{}: {e}", super::error::shown(id)),
        }))
    }

    /// The level's id: its BabyAI id, or the paper's as `groundscope-PaperLocalS{S}N{N}-v0`
    /// (the id its minigrid class has in the dumps). The done-action mode is not part of it.
    pub fn id(&self) -> String {
        match self.babyai {
            Some(id) => id.id().to_owned(),
            None => format!("{PAPER_PREFIX}{}N{}-v0", self.room_size, self.n_objects),
        }
    }

    /// `max_steps = S²` (BabyAI: one navigation in a 1×1 maze); a BabyAI level's horizon
    /// may depend on its instruction, so use the generated world's.
    pub fn max_steps(&self) -> u32 {
        (self.room_size * self.room_size) as u32
    }

    /// The level as a BabyAI level spec: one room of `room_size`, BabyAI's GoToLocal
    /// generation (see [`crate::env::babyai::goto::paper`]).
    pub fn spec(&self) -> LevelSpec {
        LevelSpec {
            id: "groundscope-paper",
            rooms: Rooms {
                room_size: self.room_size as i32,
                num_cols: 1,
                num_rows: 1,
            },
            max_steps: Some(self.max_steps()),
            family: Family::Paper {
                num_dists: self.n_objects,
                tasks: self.tasks,
                color_optional: self.color_optional,
            },
        }
    }

    /// The registered BabyAI id this config generates exactly, if any (go-to only, colour
    /// always named, a registered size).
    pub fn babyai_id(&self) -> Option<&'static str> {
        if self.tasks != TaskSet::GoTo || self.color_optional {
            return None;
        }
        let id = format!("BabyAI-GoToLocalS{}N{}-v0", self.room_size, self.n_objects);
        crate::env::babyai::spec(&id).map(|s| s.id)
    }

    /// Generates the level for `seed` as minigrid's `reset(seed=seed)` would; the same
    /// config and seed give the same world.
    pub fn generate(&self, seed: u64) -> Result<World, EnvError> {
        self.validate()?;
        if let Some(id) = self.babyai {
            return crate::env::babyai::generate(id.spec(), seed, self.done_required);
        }
        crate::env::babyai::generate(&self.spec(), seed, self.done_required)
    }
}

/// `check_objs_reachable`: every non-wall object is 4-adjacent to the agent's component of
/// empty (or enterable) cells.
pub fn all_reachable(grid: &Grid, agent_pos: Pos) -> bool {
    grid.all_objects_reachable(agent_pos)
}

/// The world of BabyAI level `id` at `seed` (done mode off), for unit tests across modules.
#[cfg(test)]
pub(crate) fn babyai_world(id: &str, seed: u64) -> World {
    LevelConfig::babyai(LevelId::parse(id).unwrap(), false)
        .generate(seed)
        .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::object::{Color, ObjectKind, WorldObj};
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// The flood fill as first written, on positions: the reference for the index version.
    fn reachable_reference(grid: &Grid, agent_pos: Pos) -> bool {
        let (w, h) = (grid.width(), grid.height());
        let mut seen = vec![false; w * h];
        let idx = |(x, y): Pos| x as usize * h + y as usize;
        let mut stack = vec![agent_pos];
        seen[idx(agent_pos)] = true;
        while let Some((x, y)) = stack.pop() {
            if grid.get((x, y)).is_some_and(|o| o.kind != ObjectKind::Door) && (x, y) != agent_pos {
                continue;
            }
            for n in [(x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)] {
                if !grid.contains(n) || seen[idx(n)] {
                    continue;
                }
                if grid.get(n).is_some_and(|o| o.kind == ObjectKind::Wall) {
                    continue;
                }
                seen[idx(n)] = true;
                stack.push(n);
            }
        }
        grid.objects()
            .filter(|(_, o)| o.kind != ObjectKind::Wall)
            .all(|(p, _)| seen[idx(p)])
    }

    #[test]
    fn reachability_matches_the_position_flood_fill() {
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let kinds = [
            ObjectKind::Wall,
            ObjectKind::Door,
            ObjectKind::Ball,
            ObjectKind::Key,
        ];
        let (mut yes, mut no) = (0, 0);
        // Up to 9 × 9 (one word of bits and the multi-word mask), then up to 29 × 29 sparser
        // (the multi-word mask up to 512 cells, the cell-by-cell fill beyond).
        for k in 0..6000 {
            let (max, num, den) = if k < 3000 { (10, 2, 5) } else { (30, 1, 12) };
            let (w, h) = (rng.random_range(1..max), rng.random_range(1..max));
            let mut grid = Grid::new(w, h);
            for x in 0..w as i32 {
                for y in 0..h as i32 {
                    if rng.random_ratio(num, den) {
                        let kind = kinds[rng.random_range(0..kinds.len())];
                        grid.set((x, y), Some(WorldObj::new(kind, Color::Red, 1)));
                    }
                }
            }
            let agent = (rng.random_range(0..w as i32), rng.random_range(0..h as i32));
            let want = reachable_reference(&grid, agent);
            assert_eq!(all_reachable(&grid, agent), want, "{w}×{h} from {agent:?}");
            if want { yes += 1 } else { no += 1 }
        }
        assert!(yes > 200 && no > 200, "both outcomes covered: {yes} / {no}");
    }

    #[test]
    fn same_seed_same_world() {
        let cfg = LevelConfig::default();
        for seed in 0..20 {
            assert_eq!(cfg.generate(seed).unwrap(), cfg.generate(seed).unwrap());
        }
        assert_ne!(cfg.generate(1).unwrap(), cfg.generate(2).unwrap());
    }

    #[test]
    fn invalid_configs_name_the_field() {
        let small = LevelConfig {
            room_size: 4,
            ..LevelConfig::default()
        };
        assert!(
            small
                .validate()
                .unwrap_err()
                .to_string()
                .contains("room_size")
        );
        let crowded = LevelConfig {
            room_size: 5,
            n_objects: 9,
            ..LevelConfig::default()
        };
        assert!(
            crowded
                .validate()
                .unwrap_err()
                .to_string()
                .contains("n_objects")
        );
    }

    #[test]
    fn generated_missions_follow_babyai() {
        let cfg = LevelConfig::default();
        let (mut the, mut a, mut no_color, mut pickup) = (0, 0, 0, 0);
        for seed in 0..2000 {
            let w = cfg.generate(seed).unwrap();
            assert_eq!(w.max_steps, 64);
            let n = w.targets().len();
            assert!(n >= 1);
            if w.mission.contains(" the ") {
                the += 1;
                assert_eq!(n, 1, "{}", w.mission);
            } else {
                a += 1;
                assert!(n > 1, "{}", w.mission);
            }
            no_color += usize::from(w.desc().color.is_none());
            pickup += usize::from(w.instr.first().instr.task == TaskKind::Pickup);
            for (p, o) in w.grid.objects() {
                if o.kind != ObjectKind::Wall {
                    let d = (p.0 - w.agent_pos.0).abs() + (p.1 - w.agent_pos.1).abs();
                    assert!(d >= 2, "object at distance {d} from the agent");
                }
            }
        }
        assert!(the > a && a > 0);
        assert!(
            (200..400).contains(&no_color),
            "no colour in {no_color} of 2000"
        );
        assert!((900..1100).contains(&pickup), "pickup in {pickup} of 2000");
    }
}
