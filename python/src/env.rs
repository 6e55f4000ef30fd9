//! One environment as minigrid 3.2.0 runs it: a level, the env's own numpy generator and the
//! current world. `reset(seed)` reseeds the generator; `reset()` without a seed continues it
//! (minigrid's `reset(seed=None)` keeps drawing from the env's `np_random`), so a sequence of
//! resets gives the same levels as the Python env's.

use groundscope::env::babyai::{self, LevelSpec};
use groundscope::env::rng::NumpyRng;
use groundscope::env::{Action, EnvError, LevelConfig, StepOutcome, World};
use numpy::{PyArray1, PyArray3, PyArrayMethods as _};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// Bytes of one observation image (7 × 7 × 3, x-major as minigrid's `obs["image"]`).
pub const IMAGE_BYTES: usize = 7 * 7 * 3;

/// The prefix gymnasium registers groundscope's envs under.
pub const NAMESPACE: &str = "groundscope/";

/// A level by its id: a registered BabyAI level or the paper's `groundscope-PaperLocal…`.
#[derive(Clone, Debug)]
pub struct Level {
    /// What generates it.
    pub spec: LevelSpec,
    /// The same level as the metrics and the CLI name it.
    pub config: LevelConfig,
}

impl Level {
    /// The level registered as `id` (with or without the `groundscope/` namespace).
    pub fn parse(id: &str) -> Result<Self, EnvError> {
        // minigrid's default: no done action (BABYAI_DONE_ACTIONS unset), as `from_id` gives.
        let config = LevelConfig::from_id(id.strip_prefix(NAMESPACE).unwrap_or(id))?;
        let spec = config.babyai.map_or_else(|| config.spec(), |l| *l.spec());
        Ok(Self { spec, config })
    }

    /// [`Self::parse`] for Python: every error is the caller's id (`ValueError`).
    pub fn parse_py(id: &str) -> PyResult<Self> {
        Self::parse(id).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The id without the namespace.
    pub fn name(&self) -> String {
        self.config.id()
    }
}

/// A Python exception for an env error: bad ids and configs are the caller's (`ValueError`),
/// anything else is the env's (`RuntimeError`).
pub fn py_err(e: &EnvError) -> PyErr {
    match e {
        EnvError::InvalidConfig { .. } => PyValueError::new_err(e.to_string()),
        _ => PyRuntimeError::new_err(e.to_string()),
    }
}

/// A seed gymnasium accepts: a non-negative int (numpy's SeedSequence takes any size; the port
/// takes 64 bits, which covers every seed anyone passes).
pub fn check_seed(seed: &Bound<'_, PyAny>, what: &str) -> PyResult<Option<u64>> {
    if seed.is_none() {
        return Ok(None);
    }
    if seed.is_instance_of::<pyo3::types::PyBool>() {
        return Err(PyValueError::new_err(format!(
            "{what} must be a non-negative int or None, not a bool"
        )));
    }
    let Ok(value) = seed.extract::<i128>() else {
        return Err(PyValueError::new_err(format!(
            "{what} must be a non-negative int or None, got {}",
            seed.repr().map_or_else(|_| "?".into(), |r| r.to_string())
        )));
    };
    u64::try_from(value).map(Some).map_err(|_| {
        PyValueError::new_err(format!(
            "{what} must be a non-negative int below 2**64, got {value}"
        ))
    })
}

/// A seed for an env reset without one before it was ever seeded (gymnasium then seeds from
/// the OS's entropy).
fn entropy_seed() -> u64 {
    rand::random()
}

/// One env: level, generator and world.
#[derive(Clone, Debug)]
pub struct EnvCore {
    /// The level it generates.
    pub level: Level,
    rng: Option<NumpyRng>,
    seed: u64,
    /// The current episode (`None` before the first reset).
    pub world: Option<World>,
}

impl EnvCore {
    /// An env that has not been reset.
    pub fn new(level: Level) -> Self {
        Self {
            level,
            rng: None,
            seed: 0,
            world: None,
        }
    }

    /// `reset(seed=seed)`: a new generator from `seed`, or the env's own continued.
    pub fn reset(&mut self, seed: Option<u64>) -> Result<(), EnvError> {
        if let Some(s) = seed {
            self.rng = Some(NumpyRng::new(s));
            self.seed = s;
        }
        let seed = self.seed;
        let rng = self.rng.get_or_insert_with(|| {
            let s = entropy_seed();
            self.seed = s;
            NumpyRng::new(s)
        });
        let world = babyai::generate_continuing(
            &self.level.spec,
            rng,
            seed,
            self.level.config.done_required,
        )?;
        self.world = Some(world);
        Ok(())
    }

    /// One step; errors before the first reset or after the episode ended.
    pub fn step(&mut self, action: Action) -> Result<StepOutcome, EnvError> {
        match &mut self.world {
            Some(w) => w.step(action),
            None => Err(EnvError::InvalidState {
                field: "reset".into(),
                reason: "step() before reset(): call reset() first".into(),
            }),
        }
    }

    /// Writes the observation image into `out` (147 bytes) and returns the direction.
    pub fn write_obs(&self, out: &mut [u8]) -> i64 {
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
        i64::from(w.agent_dir)
    }

    /// The mission text of the current episode.
    pub fn mission(&self) -> &str {
        self.world.as_ref().map_or("", |w| w.mission.as_str())
    }
}

/// The action at index `a`, or a `ValueError` naming it.
pub fn action(a: i64, what: &str) -> PyResult<Action> {
    usize::try_from(a)
        .ok()
        .and_then(Action::from_index)
        .ok_or_else(|| PyValueError::new_err(format!("{what} must be an action 0-6, got {a}")))
}

/// One environment (`groundscope._core.Env`); `groundscope.make` wraps it in a gymnasium.Env.
#[pyclass(module = "groundscope._core")]
pub struct Env {
    core: EnvCore,
}

/// `(image (7,7,3) uint8, direction, mission)`.
type PyObs<'py> = (Bound<'py, PyArray3<u8>>, i64, String);

fn obs<'py>(py: Python<'py>, core: &EnvCore) -> PyResult<PyObs<'py>> {
    let mut image = vec![0u8; IMAGE_BYTES];
    let dir = core.write_obs(&mut image);
    let image = PyArray1::from_vec(py, image).reshape([7, 7, 3])?;
    Ok((image, dir, core.mission().to_owned()))
}

#[pymethods]
impl Env {
    /// The env of level `id`; an unknown id is a `ValueError` naming the closest ones.
    #[new]
    fn new(id: &str) -> PyResult<Self> {
        let level = Level::parse_py(id)?;
        Ok(Self {
            core: EnvCore::new(level),
        })
    }

    /// Starts an episode: with a seed, the generator minigrid's `reset(seed=seed)` builds;
    /// without, the env's generator continued. Returns `(image, direction, mission)`.
    #[pyo3(signature = (seed=None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: Option<Bound<'py, PyAny>>,
    ) -> PyResult<PyObs<'py>> {
        let seed = match &seed {
            Some(s) => check_seed(s, "seed")?,
            None => None,
        };
        self.core.reset(seed).map_err(|e| py_err(&e))?;
        obs(py, &self.core)
    }

    /// One step: `(image, direction, mission, reward, terminated, truncated)`.
    #[expect(clippy::type_complexity, reason = "a Python tuple")]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: i64,
    ) -> PyResult<(Bound<'py, PyArray3<u8>>, i64, String, f64, bool, bool)> {
        let a = self::action(action, "action")?;
        let out = match self.core.step(a) {
            Ok(o) => o,
            Err(EnvError::EpisodeEnded { .. }) => {
                return Err(PyRuntimeError::new_err(
                    "step() after the episode ended (terminated or truncated): call reset()",
                ));
            }
            Err(e) => return Err(py_err(&e)),
        };
        let (image, dir, mission) = obs(py, &self.core)?;
        Ok((
            image,
            dir,
            mission,
            out.reward,
            out.terminated,
            out.truncated,
        ))
    }

    /// The level's id (the paper's as `groundscope-PaperLocalS{S}N{N}-v0`).
    #[getter]
    fn level(&self) -> String {
        self.core.level.name()
    }

    /// The current episode's horizon (`max_steps`, which depends on the mission in BabyAI).
    #[getter]
    fn max_steps(&self) -> Option<u32> {
        self.core.world.as_ref().map(|w| w.max_steps)
    }

    /// Steps taken in the current episode.
    #[getter]
    fn step_count(&self) -> Option<u32> {
        self.core.world.as_ref().map(|w| w.step_count)
    }

    /// The agent's position `(x, y)` in the world.
    #[getter]
    fn agent_pos(&self) -> Option<(i32, i32)> {
        self.core.world.as_ref().map(|w| w.agent_pos)
    }
}

/// Every registered BabyAI id of minigrid 3.2.0, in registration order.
#[pyfunction]
pub fn level_ids() -> Vec<&'static str> {
    babyai::level_ids().collect()
}
