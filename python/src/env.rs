//! One environment as minigrid 3.2.0 runs it: a level, the env's own numpy generator and the
//! current world. `reset(seed)` reseeds the generator; `reset()` without a seed continues it
//! (minigrid's `reset(seed=None)` keeps drawing from the env's `np_random`), so a sequence of
//! resets gives the same levels as the Python env's.

use groundscope::env::babyai;
use groundscope::env::gym::MinigridEnv;
use groundscope::env::{Action, EnvError, LevelConfig};
use numpy::{PyArray1, PyArray3, PyArrayMethods as _};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pub use groundscope::env::gym::IMAGE_BYTES;

/// The prefix gymnasium registers groundscope's envs under.
pub const NAMESPACE: &str = "groundscope/";

/// The level registered as `id` (with or without the `groundscope/` namespace): a BabyAI
/// id in its registered mode or the paper's `groundscope-PaperLocal…`; every error is the
/// caller's id (`ValueError`). Parsed once, here, by the core's one parser.
pub fn parse_level(id: &str) -> PyResult<LevelConfig> {
    LevelConfig::from_id(id.strip_prefix(NAMESPACE).unwrap_or(id))
        .map_err(|e| PyValueError::new_err(e.to_string()))
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

/// `value`'s repr, for an error message.
fn shown(value: &Bound<'_, PyAny>) -> String {
    value.repr().map_or_else(|_| "?".into(), |r| r.to_string())
}

/// A Python int argument as an `i128`, or a `ValueError` naming it (`what`) and what it must
/// be (`want`): a bool, a float, a str or an int past 128 bits is refused here, where PyO3's
/// conversion into a Rust integer raises an `OverflowError` or `TypeError` that names no
/// argument.
fn int_value(value: &Bound<'_, PyAny>, what: &str, want: &str) -> PyResult<i128> {
    if value.is_instance_of::<pyo3::types::PyBool>() {
        return Err(PyValueError::new_err(format!(
            "{what} must be {want}, not a bool"
        )));
    }
    value
        .extract::<i128>()
        .map_err(|_| PyValueError::new_err(format!("{what} must be {want}, got {}", shown(value))))
}

/// A non-negative int argument below 2**64 (a seed, a count), or a `ValueError` naming it.
pub fn u64_arg(value: &Bound<'_, PyAny>, what: &str) -> PyResult<u64> {
    let want = "a non-negative int below 2**64";
    let v = int_value(value, what, want)?;
    u64::try_from(v).map_err(|_| PyValueError::new_err(format!("{what} must be {want}, got {v}")))
}

/// [`u64_arg`] as a `usize` (a size, a count of items).
pub fn usize_arg(value: &Bound<'_, PyAny>, what: &str) -> PyResult<usize> {
    let v = u64_arg(value, what)?;
    usize::try_from(v).map_err(|_| {
        PyValueError::new_err(format!(
            "{what} must be a non-negative int below 2**64, got {v}"
        ))
    })
}

/// [`u64_arg`] of an optional argument: `None` (left out) stays `None`.
pub fn opt_u64_arg(value: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<u64>> {
    value.map(|v| u64_arg(v, what)).transpose()
}

/// [`usize_arg`] of an optional argument: `None` (left out) stays `None`.
pub fn opt_usize_arg(value: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<usize>> {
    value.map(|v| usize_arg(v, what)).transpose()
}

/// The action a Python int names in an env of `num_actions` actions ([`env_action`]), an
/// int of any size: one past 64 bits is a `ValueError` naming it as any other bad action (on
/// Dynamic-Obstacles, whose `step` acts `left` at or past 3, it is `left`, as there).
pub fn py_env_action(a: &Bound<'_, PyAny>, num_actions: usize, what: &str) -> PyResult<Action> {
    let bad = |v: String| PyValueError::new_err(format!("{what} must be an action 0-6, got {v}"));
    let Ok(value) = a.extract::<i128>() else {
        return Err(bad(shown(a)));
    };
    match i64::try_from(value) {
        Ok(v) => env_action(v, num_actions, what),
        Err(_) if value > 0 && num_actions < Action::COUNT => Ok(Action::Left),
        Err(_) => Err(bad(value.to_string())),
    }
}

/// A seed for an env reset without one before it was ever seeded (gymnasium then seeds from
/// the OS's entropy).
pub fn entropy_seed() -> u64 {
    rand::random()
}

/// The action an env of `num_actions` actions takes for `a`: Dynamic-Obstacles (3 actions)
/// acts `left` for any action at or past 3, as its `step` does; else [`action`].
pub fn env_action(a: i64, num_actions: usize, what: &str) -> PyResult<Action> {
    if num_actions < Action::COUNT && a >= num_actions as i64 {
        return Ok(Action::Left);
    }
    action(a, what)
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
    core: MinigridEnv,
}

/// `(image (7,7,3) uint8, direction, mission)`.
type PyObs<'py> = (Bound<'py, PyArray3<u8>>, i64, String);

fn obs<'py>(py: Python<'py>, core: &MinigridEnv) -> PyResult<PyObs<'py>> {
    let mut image = vec![0u8; IMAGE_BYTES];
    let dir = core.write_obs(&mut image);
    let image = PyArray1::from_vec(py, image).reshape([7, 7, 3])?;
    Ok((image, i64::from(dir), core.mission().to_owned()))
}

#[pymethods]
impl Env {
    /// The env of level `id`; an unknown id is a `ValueError` naming the closest ones.
    #[new]
    fn new(id: &str) -> PyResult<Self> {
        let level = parse_level(id)?;
        Ok(Self {
            core: MinigridEnv::new(level),
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
        self.core
            .reset(seed, entropy_seed)
            .map_err(|e| py_err(&e))?;
        obs(py, &self.core)
    }

    /// One step: `(image, direction, mission, reward, terminated, truncated)`.
    #[expect(clippy::type_complexity, reason = "a Python tuple")]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyArray3<u8>>, i64, String, f64, bool, bool)> {
        let a = py_env_action(&action, self.core.num_actions(), "action")?;
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
        self.core.level.id()
    }

    /// The size of the action space (3 on Dynamic-Obstacles, else 7).
    #[getter]
    fn num_actions(&self) -> usize {
        self.core.num_actions()
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

/// Every registered id of minigrid 3.2.0 that groundscope builds: BabyAI's 96, then
/// MiniGrid's 76.
#[pyfunction]
pub fn level_ids() -> Vec<&'static str> {
    babyai::all_ids().collect()
}
