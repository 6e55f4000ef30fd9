//! One environment as minigrid 3.2.0 runs it behind gymnasium's API: a level, the env's own
//! numpy generator and the current world. `reset(Some(seed))` reseeds the generator;
//! `reset(None)` continues it (minigrid's `reset(seed=None)` keeps drawing from the env's
//! `np_random`), so a sequence of resets gives the same levels as the Python env's. What the
//! Python package's `Env` and `VecEnv` step; pure (a first reset without a seed takes the one
//! its caller draws).

use super::babyai::{self, LevelSpec};
use super::error::EnvError;
use super::level::LevelConfig;
use super::minigrid::Rules;
use super::rng::NumpyRng;
use super::world::{Action, StepOutcome, World};

/// Bytes of one observation image (7 × 7 × 3, x-major as minigrid's `obs["image"]`).
pub const IMAGE_BYTES: usize = 7 * 7 * 3;

/// One env: level, generator and world.
#[derive(Clone, Debug)]
pub struct MinigridEnv {
    /// The level it generates, in its done mode.
    pub level: LevelConfig,
    spec: LevelSpec,
    rng: Option<NumpyRng>,
    seed: u64,
    /// The current episode (`None` before the first reset).
    pub world: Option<World>,
}

impl MinigridEnv {
    /// An env of `level` that has not been reset.
    pub fn new(level: LevelConfig) -> Self {
        Self {
            spec: level.babyai.map_or_else(|| level.spec(), |id| *id.spec()),
            level,
            rng: None,
            seed: 0,
            world: None,
        }
    }

    /// `reset(seed=seed)`: a new generator from `seed`, or the env's own continued; the first
    /// reset without a seed seeds it with `fresh()` (gymnasium: the OS's entropy).
    pub fn reset(
        &mut self,
        seed: Option<u64>,
        fresh: impl FnOnce() -> u64,
    ) -> Result<(), EnvError> {
        if let Some(s) = seed {
            self.rng = Some(NumpyRng::new(s));
            self.seed = s;
        } else if let Some(w) = &self.world
            && let Some(Rules::DynamicObstacles { rng, .. }) = &w.rules
        {
            // Dynamic-Obstacles' balls drew from the env's stream at every step: the next
            // level continues from where the last step left it.
            self.rng = Some(rng.clone());
        }
        if self.rng.is_none() {
            self.seed = fresh();
            self.rng = Some(NumpyRng::new(self.seed));
        }
        let seed = self.seed;
        let rng = self.rng.as_mut().ok_or_else(|| EnvError::InvalidState {
            field: "reset".into(),
            reason: "no generator".into(),
        })?;
        self.world = Some(babyai::generate_continuing(
            &self.spec,
            rng,
            seed,
            self.level.done_required,
        )?);
        Ok(())
    }

    /// One step; an error before the first reset or after the episode ended.
    pub fn step(&mut self, action: Action) -> Result<StepOutcome, EnvError> {
        match &mut self.world {
            Some(w) => w.step(action),
            None => Err(EnvError::InvalidState {
                field: "reset".into(),
                reason: "step() before reset(): call reset() first".into(),
            }),
        }
    }

    /// Writes the observation image into `out` ([`IMAGE_BYTES`], x-major) and returns the
    /// agent's direction; zeros and 0 before the first reset.
    pub fn write_obs(&self, out: &mut [u8]) -> u8 {
        let Some(w) = &self.world else {
            out.fill(0);
            return 0;
        };
        let obs = w.observe();
        for (dst, src) in out
            .chunks_exact_mut(3)
            .zip(obs.image.iter().flat_map(|col| col.iter()))
        {
            dst.copy_from_slice(src);
        }
        w.agent_dir
    }

    /// The size of the action space: 3 on Dynamic-Obstacles (left, right, forward), else 7.
    pub fn num_actions(&self) -> usize {
        match self.spec.family {
            babyai::Family::MiniGrid(c) => c.num_actions(),
            _ => Action::COUNT,
        }
    }

    /// The mission text of the current episode ("" before the first reset).
    pub fn mission(&self) -> &str {
        self.world.as_ref().map_or("", |w| w.mission.as_str())
    }
}
