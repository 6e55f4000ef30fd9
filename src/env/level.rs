//! Level configurations and BabyAI's GoToLocal-style generator.
//!
//! The generator reproduces `GoToLocal.gen_mission` in distribution (not bit for bit: numpy's
//! PCG64 stream is not reproduced): the agent first, on a uniform interior cell with a uniform
//! direction; then N objects of uniform type (key, ball, box) and colour, on uniform empty
//! cells at Manhattan distance ≥ 2 from the agent (duplicates allowed); the whole layout is
//! redrawn when an object is unreachable; the target is a uniform pick among the objects and
//! every object with its type and colour counts. Task kind is uniform over the configured
//! kinds. With `color_optional` the colour is left out with probability 1/7, the chance
//! BabyAI's `rand_obj` gives `None` among `[None, *COLOR_NAMES]`.

use std::fmt;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use super::error::EnvError;
use super::grid::{Grid, Pos};
use super::mission::{Instruction, ObjDesc, TaskKind};
use super::object::{Color, ObjectKind, WorldObj};
use super::world::World;

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
}

impl Default for LevelConfig {
    /// The paper's level: S = 8, N = 4, go to and pick up, done required, colour optional.
    fn default() -> Self {
        Self {
            room_size: 8,
            n_objects: 4,
            tasks: TaskSet::Both,
            done_required: true,
            color_optional: true,
        }
    }
}

impl fmt::Display for LevelConfig {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
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

/// Attempts before generation gives up (BabyAI retries forever; a valid config never gets close).
const MAX_LAYOUT_TRIES: u32 = 10_000;

impl LevelConfig {
    /// Checks the config, naming the field at fault.
    pub fn validate(&self) -> Result<(), EnvError> {
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

    /// `max_steps = S²` (BabyAI: one navigation in a 1×1 maze).
    pub fn max_steps(&self) -> u32 {
        (self.room_size * self.room_size) as u32
    }

    /// Generates the level for `seed`; the same config and seed give the same world.
    pub fn generate(&self, seed: u64) -> Result<World, EnvError> {
        self.validate()?;
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        for _ in 0..MAX_LAYOUT_TRIES {
            if let Some(world) = self.try_layout(&mut rng)? {
                return Ok(world);
            }
        }
        Err(EnvError::GenerationFailed {
            seed,
            tries: MAX_LAYOUT_TRIES,
        })
    }

    /// One layout attempt; `None` when rejection sampling failed (BabyAI regenerates).
    fn try_layout(&self, rng: &mut Pcg64Mcg) -> Result<Option<World>, EnvError> {
        let s = self.room_size as i32;
        let mut grid = Grid::new(self.room_size, self.room_size);
        let mut next_id = 0;
        grid.wall_ring(&mut next_id);
        let agent_pos = (rng.random_range(1..s - 1), rng.random_range(1..s - 1));
        let agent_dir = rng.random_range(0..4u8);
        let mut objs: Vec<WorldObj> = Vec::with_capacity(self.n_objects);
        for _ in 0..self.n_objects {
            let kind = ObjectKind::PICKABLE[rng.random_range(0..3)];
            let color = Color::ALL[rng.random_range(0..6)];
            let obj = WorldObj::new(kind, color, next_id);
            next_id += 1;
            let Some(pos) = place_obj(&grid, agent_pos, rng) else {
                return Ok(None);
            };
            grid.set(pos, Some(obj));
            objs.push(obj);
        }
        if !all_reachable(&grid, agent_pos) {
            return Ok(None);
        }
        let task = self.tasks.kinds()[rng.random_range(0..self.tasks.kinds().len())];
        let target = objs[rng.random_range(0..objs.len())];
        let color = if self.color_optional && rng.random_ratio(1, 7) {
            None
        } else {
            Some(target.color)
        };
        let instr = Instruction {
            task,
            desc: ObjDesc {
                kind: Some(target.kind),
                color,
                loc: None,
            },
            strict: false,
        };
        World::new(
            grid,
            agent_pos,
            agent_dir,
            None,
            instr,
            self.max_steps(),
            self.done_required,
            next_id,
        )
        .map(Some)
    }
}

/// `place_obj` with `reject_next_to`: uniform over the whole grid rectangle (walls rejected),
/// not on the agent, Manhattan distance ≥ 2 from it; at most 1000 tries.
fn place_obj(grid: &Grid, agent_pos: Pos, rng: &mut Pcg64Mcg) -> Option<Pos> {
    let (w, h) = (grid.width() as i32, grid.height() as i32);
    for _ in 0..1000 {
        let pos = (rng.random_range(0..w), rng.random_range(0..h));
        if grid.get(pos).is_some() || pos == agent_pos {
            continue;
        }
        if (pos.0 - agent_pos.0).abs() + (pos.1 - agent_pos.1).abs() < 2 {
            continue;
        }
        return Some(pos);
    }
    None
}

/// `check_objs_reachable`: every non-wall object is 4-adjacent to the agent's component of
/// empty (or enterable) cells.
pub fn all_reachable(grid: &Grid, agent_pos: Pos) -> bool {
    grid.all_objects_reachable(agent_pos)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        for _ in 0..3000 {
            let (w, h) = (rng.random_range(1..10usize), rng.random_range(1..10usize));
            let mut grid = Grid::new(w, h);
            for x in 0..w as i32 {
                for y in 0..h as i32 {
                    if rng.random_ratio(2, 5) {
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
        assert!(yes > 100 && no > 100, "both outcomes covered: {yes} / {no}");
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
            let n = w.verifier.obj_set.len();
            assert!(n >= 1);
            if w.mission.contains(" the ") {
                the += 1;
                assert_eq!(n, 1, "{}", w.mission);
            } else {
                a += 1;
                assert!(n > 1, "{}", w.mission);
            }
            no_color += usize::from(w.instr.desc.color.is_none());
            pickup += usize::from(w.instr.task == TaskKind::Pickup);
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
