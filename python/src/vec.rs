//! N envs stepped together (`groundscope._core.VecEnv`), as gymnasium 1.x's `SyncVectorEnv`
//! with `autoreset_mode = NEXT_STEP` steps minigrid envs: an env that ended on the previous
//! step is reset (its own generator continued) instead of stepped, with reward 0 and both
//! flags false. The envs run on a thread pool with the GIL released; observations, rewards and
//! flags are written into the caller's preallocated numpy arrays, so a step allocates nothing
//! but the missions of the envs that reset.

use groundscope::env::{Action, EnvError};
use numpy::{PyReadonlyArray1, PyReadwriteArray1, PyReadwriteArray4, PyUntypedArrayMethods as _};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::env::{
    IMAGE_BYTES, check_seed, entropy_seed, env_action, opt_usize_arg, parse_level, py_err,
    usize_arg,
};
use groundscope::env::gym::MinigridEnv;

/// Envs per task handed to a thread: small enough to balance, large enough that a task is
/// worth its scheduling (a step is ~1 µs).
const ENVS_PER_TASK: usize = 8;

/// The vector env's core; `groundscope.make_vec` wraps it in a gymnasium VectorEnv.
#[pyclass(module = "groundscope._core")]
pub struct VecEnv {
    envs: Vec<MinigridEnv>,
    /// Ended on the last step: reset on the next (NEXT_STEP).
    autoreset: Vec<bool>,
    /// `None`: step on the calling thread.
    pool: Option<rayon::ThreadPool>,
}

/// What one env did in a step, gathered before the results are written.
struct Slot<'a> {
    env: &'a mut MinigridEnv,
    autoreset: &'a mut bool,
    image: &'a mut [u8],
    direction: &'a mut i64,
    reward: &'a mut f64,
    terminated: &'a mut bool,
    truncated: &'a mut bool,
    action: Action,
    /// Set when the env reset this step (its mission changed).
    reset: bool,
}

impl Slot<'_> {
    fn run(&mut self) -> Result<(), EnvError> {
        if *self.autoreset {
            self.env.reset(None, entropy_seed)?;
            *self.reward = 0.0;
            *self.terminated = false;
            *self.truncated = false;
            self.reset = true;
        } else {
            let out = self.env.step(self.action)?;
            *self.reward = out.reward;
            *self.terminated = out.terminated;
            *self.truncated = out.truncated;
        }
        *self.autoreset = *self.terminated || *self.truncated;
        *self.direction = i64::from(self.env.write_obs(self.image));
        Ok(())
    }
}

fn check_len(name: &str, len: usize, n: usize) -> PyResult<()> {
    if len == n {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "{name} has {len} entries for {n} envs"
        )))
    }
}

fn slices<'a, T: numpy::Element>(
    name: &str,
    a: &'a mut PyReadwriteArray1<'_, T>,
    n: usize,
) -> PyResult<&'a mut [T]> {
    check_len(name, a.len(), n)?;
    a.as_slice_mut()
        .map_err(|_| PyValueError::new_err(format!("{name} must be a contiguous array")))
}

fn image_slice<'a>(a: &'a mut PyReadwriteArray4<'_, u8>, n: usize) -> PyResult<&'a mut [u8]> {
    if a.shape() != [n, 7, 7, 3] {
        return Err(PyValueError::new_err(format!(
            "image must have shape ({n}, 7, 7, 3), got {:?}",
            a.shape()
        )));
    }
    a.as_slice_mut()
        .map_err(|_| PyValueError::new_err("image must be a contiguous array"))
}

/// The most envs one vector holds (each about 10 KB: 640 MB at the bound).
pub const MAX_ENVS: usize = 1 << 16;
/// The most threads a vector steps on.
pub const MAX_THREADS: usize = 1024;

#[pymethods]
impl VecEnv {
    /// `num_envs` envs of level `id`, stepped on `num_threads` threads (0: one per core;
    /// 1: the calling thread).
    #[new]
    #[pyo3(signature = (id, num_envs, num_threads=None))]
    fn new(
        id: &str,
        num_envs: Bound<'_, PyAny>,
        num_threads: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let num_envs = usize_arg(&num_envs, "num_envs")?;
        let num_threads = opt_usize_arg(num_threads.as_ref(), "num_threads")?.unwrap_or(0);
        if num_envs == 0 {
            return Err(PyValueError::new_err("num_envs must be at least 1, got 0"));
        }
        // Past these a vector does not fit in memory (an env holds its grid and generator) or
        // the system stalls creating threads; refused before anything is allocated.
        if num_envs > MAX_ENVS {
            return Err(PyValueError::new_err(format!(
                "num_envs must be at most {MAX_ENVS}, got {num_envs}"
            )));
        }
        if num_threads > MAX_THREADS {
            return Err(PyValueError::new_err(format!(
                "num_threads must be at most {MAX_THREADS}, got {num_threads}"
            )));
        }
        let level = parse_level(id)?;
        let threads = if num_threads == 0 {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        } else {
            num_threads
        };
        let pool = if threads > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .thread_name(|i| format!("groundscope-env-{i}"))
                    .build()
                    .map_err(|e| PyRuntimeError::new_err(format!("thread pool: {e}")))?,
            )
        } else {
            None
        };
        Ok(Self {
            envs: vec![MinigridEnv::new(level); num_envs],
            autoreset: vec![false; num_envs],
            pool,
        })
    }

    /// Resets the envs where `mask` is true (all without a mask) with `seeds` (one int or
    /// None per env), writing their observations; returns every env's mission.
    #[pyo3(signature = (seeds, image, direction, mask=None))]
    fn reset(
        &mut self,
        seeds: Vec<Bound<'_, PyAny>>,
        mut image: PyReadwriteArray4<'_, u8>,
        mut direction: PyReadwriteArray1<'_, i64>,
        mask: Option<PyReadonlyArray1<'_, bool>>,
    ) -> PyResult<Vec<String>> {
        let n = self.envs.len();
        check_len("seed", seeds.len(), n)?;
        let seeds = seeds
            .iter()
            .enumerate()
            .map(|(i, s)| check_seed(s, &format!("seed[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        let mask = match &mask {
            Some(m) => {
                check_len("reset_mask", m.len(), n)?;
                m.as_array().to_vec()
            }
            None => vec![true; n],
        };
        let image = image_slice(&mut image, n)?;
        let direction = slices("direction", &mut direction, n)?;
        for i in (0..n).filter(|&i| mask[i]) {
            self.envs[i]
                .reset(seeds[i], entropy_seed)
                .map_err(|e| py_err(&e))?;
            self.autoreset[i] = false;
            direction[i] =
                i64::from(self.envs[i].write_obs(&mut image[i * IMAGE_BYTES..][..IMAGE_BYTES]));
        }
        Ok(self.envs.iter().map(|e| e.mission().to_owned()).collect())
    }

    /// One step of every env (NEXT_STEP autoreset), writing observations, rewards and flags;
    /// returns `(index, mission)` of the envs that reset.
    #[expect(clippy::too_many_arguments, reason = "the preallocated output arrays")]
    fn step(
        &mut self,
        py: Python<'_>,
        actions: PyReadonlyArray1<'_, i64>,
        mut image: PyReadwriteArray4<'_, u8>,
        mut direction: PyReadwriteArray1<'_, i64>,
        mut reward: PyReadwriteArray1<'_, f64>,
        mut terminated: PyReadwriteArray1<'_, bool>,
        mut truncated: PyReadwriteArray1<'_, bool>,
    ) -> PyResult<Vec<(usize, String)>> {
        let n = self.envs.len();
        check_len("actions", actions.len(), n)?;
        if self.envs.iter().any(|e| e.world.is_none()) {
            return Err(PyRuntimeError::new_err(
                "step() before reset(): call reset() first",
            ));
        }
        // Every action is checked before any env moves: a bad one changes nothing.
        let num_actions = self.envs[0].num_actions();
        let acts = actions
            .as_array()
            .iter()
            .enumerate()
            .map(|(i, &a)| env_action(a, num_actions, &format!("actions[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        let image = image_slice(&mut image, n)?;
        let direction = slices("direction", &mut direction, n)?;
        let reward = slices("reward", &mut reward, n)?;
        let terminated = slices("terminated", &mut terminated, n)?;
        let truncated = slices("truncated", &mut truncated, n)?;
        let mut slots: Vec<Slot<'_>> = self
            .envs
            .iter_mut()
            .zip(self.autoreset.iter_mut())
            .zip(image.chunks_exact_mut(IMAGE_BYTES))
            .zip(direction.iter_mut())
            .zip(reward.iter_mut())
            .zip(terminated.iter_mut())
            .zip(truncated.iter_mut())
            .zip(acts)
            .map(
                |(
                    ((((((env, autoreset), image), direction), reward), terminated), truncated),
                    action,
                )| Slot {
                    env,
                    autoreset,
                    image,
                    direction,
                    reward,
                    terminated,
                    truncated,
                    action,
                    reset: false,
                },
            )
            .collect();
        let pool = self.pool.as_ref();
        let result = py.detach(|| match pool {
            Some(pool) => pool.install(|| {
                slots
                    .par_iter_mut()
                    .with_min_len(ENVS_PER_TASK)
                    .try_for_each(Slot::run)
            }),
            None => slots.iter_mut().try_for_each(Slot::run),
        });
        let reset: Vec<(usize, String)> = slots
            .iter()
            .enumerate()
            .filter(|(_, s)| s.reset)
            .map(|(i, s)| (i, s.env.mission().to_owned()))
            .collect();
        result.map_err(|e| py_err(&e))?;
        Ok(reset)
    }

    /// The level's id (the paper's as `groundscope-PaperLocalS{S}N{N}-v0`).
    /// The size of each env's action space (3 on Dynamic-Obstacles, else 7).
    #[getter]
    fn num_actions(&self) -> usize {
        self.envs.first().map_or(7, MinigridEnv::num_actions)
    }

    #[getter]
    fn level(&self) -> String {
        self.envs.first().map_or_else(String::new, |e| e.level.id())
    }

    /// The number of envs.
    #[getter]
    fn num_envs(&self) -> usize {
        self.envs.len()
    }

    /// Threads the envs are stepped on.
    #[getter]
    fn num_threads(&self) -> usize {
        self.pool
            .as_ref()
            .map_or(1, rayon::ThreadPool::current_num_threads)
    }

    /// Each env's current horizon (`max_steps`).
    #[getter]
    fn max_steps(&self) -> Vec<u32> {
        self.envs
            .iter()
            .map(|e| e.world.as_ref().map_or(0, |w| w.max_steps))
            .collect()
    }
}
