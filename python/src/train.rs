//! `groundscope.train`: a training run from Python, the same [`Run`] object `groundscope train`
//! and a study's runs step — its directory, lock, resume, warm start, logs, tracked evaluation,
//! checkpoints and the clean-up after a failed start are the core's. A run made here resumes
//! with `groundscope train --resume` and the other way round.

use std::path::{Path, PathBuf};

use groundscope::policy::ppo::run_dir::{RunInfo, Tracking};
use groundscope::policy::ppo::{LevelMix, MixEntry, PpoConfig, UpdateLog};
use groundscope::policy::{ModelConfig, Variant};
use groundscope::run::{DEFAULT_SAVE_INTERVAL, HeldRun, Parent, Run, RunSpec, Start};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::env::{opt_u64_arg, opt_usize_arg, parse_level};

/// `train`'s tracked evaluation when not asked otherwise: as the command's.
const EVAL_INTERVAL: u64 = 50;
const EVAL_EPISODES: u64 = 200;

/// The settings of a new run a caller may give; on `resume=True` none may be (the run keeps
/// its own), so each is `None` unless given.
struct Settings {
    model: Option<String>,
    hidden: Option<usize>,
    lr: Option<f64>,
    procs: Option<usize>,
    frames_per_proc: Option<usize>,
    batch_size: Option<usize>,
    imitate: Option<bool>,
    ground_loss: Option<f64>,
    seed: Option<u64>,
    init: Option<String>,
}

impl Settings {
    /// The names of the settings given, in the signature's order.
    fn given(&self) -> Vec<&'static str> {
        [
            ("model", self.model.is_some()),
            ("hidden", self.hidden.is_some()),
            ("lr", self.lr.is_some()),
            ("procs", self.procs.is_some()),
            ("frames_per_proc", self.frames_per_proc.is_some()),
            ("batch_size", self.batch_size.is_some()),
            ("imitate", self.imitate.is_some()),
            ("ground_loss", self.ground_loss.is_some()),
            ("seed", self.seed.is_some()),
            ("init", self.init.is_some()),
        ]
        .into_iter()
        .filter_map(|(name, given)| given.then_some(name))
        .collect()
    }

    /// A new or warm-started run's start on `levels`, refused (naming the argument) before its
    /// directory is made.
    fn start(self, levels: LevelMix) -> PyResult<Start> {
        let bad = |e: &dyn std::fmt::Display| PyValueError::new_err(e.to_string());
        let name = self.model.as_deref().unwrap_or("attention");
        let variant = Variant::parse(name).ok_or_else(|| {
            PyValueError::new_err(format!("model {name:?} is not attention or baseline"))
        })?;
        let ppo = PpoConfig {
            lr: self.lr.unwrap_or(PpoConfig::default().lr),
            procs: self.procs.unwrap_or(PpoConfig::default().procs),
            frames_per_proc: self
                .frames_per_proc
                .unwrap_or(PpoConfig::default().frames_per_proc),
            batch_size: self.batch_size.unwrap_or(PpoConfig::default().batch_size),
            imitate: self.imitate.unwrap_or(false),
            ground_loss: self.ground_loss.unwrap_or(0.0),
            ..PpoConfig::default()
        };
        ppo.validate().map_err(|e| bad(&e))?;
        let seed = self.seed.unwrap_or(1);
        if let Some(parent) = self.init {
            if self.model.is_some() || self.hidden.is_some() {
                return Err(PyValueError::new_err(
                    "init: a warm start keeps its parent's network; leave out model and hidden",
                ));
            }
            let p = Parent::load(&parent).map_err(|e| bad(&format!("init {parent}: {e:#}")))?;
            p.check_words(&levels)
                .map_err(|e| bad(&format!("init {parent}: {e:#}")))?;
            return Ok(Start::Init {
                parent: Box::new(p),
                levels,
                ppo,
                seed,
            });
        }
        let hidden = self.hidden.unwrap_or(128);
        let model = ModelConfig {
            lstm_hidden: hidden,
            gru_hidden: hidden,
            ..ModelConfig::new(variant)
        };
        model.validate().map_err(|e| bad(&e))?;
        Ok(Start::New {
            model,
            levels,
            ppo,
            seed,
        })
    }
}

/// The levels as one id (`"BabyAI-GoToLocal-v0"`, `"groundscope:BabyAI-…"`, a paper level's
/// id) or a list of them, trained on in equal shares.
fn level_mix(levels: &Bound<'_, PyAny>) -> PyResult<LevelMix> {
    let ids: Vec<String> = match levels.extract::<String>() {
        Ok(one) => vec![one],
        Err(_) => levels.extract().map_err(|_| {
            PyValueError::new_err("levels must be a level id or a list of level ids")
        })?,
    };
    let entries = ids
        .iter()
        .map(|id| {
            Ok(MixEntry {
                level: parse_level(id)?,
                weight: 1.0,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    LevelMix::new(entries).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The last row of the run's `log.csv` as an update's log, `None` where the log has no row
/// (a run that never trained). The grounding term is not logged: 0 for a run without
/// `ground_loss`, as its updates return it, else NaN.
fn last_logged(dir: &Path, supervised: bool) -> PyResult<Option<UpdateLog>> {
    let path = dir.join("log.csv");
    let text = groundscope::files::read_regular_to_string(&path)
        .map_err(|e| PyRuntimeError::new_err(format!("{}: {e}", path.display())))?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let (Some(header), Some(row)) = (lines.next(), lines.next_back()) else {
        return Ok(None);
    };
    let names: Vec<&str> = header.split(',').collect();
    let cells: Vec<&str> = row.split(',').collect();
    let cell = |name: &str| {
        names
            .iter()
            .position(|n| *n == name)
            .and_then(|i| cells.get(i).copied())
            .map(str::trim)
            .ok_or_else(|| {
                PyRuntimeError::new_err(format!("{}: its last row has no {name}", path.display()))
            })
    };
    let bad = |name: &str, v: &str| {
        PyRuntimeError::new_err(format!(
            "{}: its last row's {name} {v:?} is not a number",
            path.display()
        ))
    };
    let count = |name: &str| -> PyResult<u64> {
        let v = cell(name)?;
        v.parse().map_err(|_| bad(name, v))
    };
    let number = |name: &str| -> PyResult<f64> {
        match cell(name)? {
            "" => Ok(f64::NAN),
            v => v.parse().map_err(|_| bad(name, v)),
        }
    };
    Ok(Some(UpdateLog {
        update: count("update")?,
        frames: count("frames")?,
        episodes: count("episodes")?,
        success_rate: number("success_rate")?,
        mean_reward: number("mean_reward")?,
        mean_length: number("mean_length")?,
        policy_loss: number("policy_loss")?,
        value_loss: number("value_loss")?,
        entropy: number("entropy")?,
        grad_norm: number("grad_norm")?,
        ground_loss: if supervised { f64::NAN } else { 0.0 },
    }))
}

/// One update's log as a dict, with the frames per second since this call began.
fn log_dict<'py>(py: Python<'py>, log: &UpdateLog, fps: f64) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("update", log.update)?;
    d.set_item("frames", log.frames)?;
    d.set_item("episodes", log.episodes)?;
    d.set_item("success_rate", log.success_rate)?;
    d.set_item("mean_reward", log.mean_reward)?;
    d.set_item("mean_length", log.mean_length)?;
    d.set_item("entropy", log.entropy)?;
    d.set_item("policy_loss", log.policy_loss)?;
    d.set_item("value_loss", log.value_loss)?;
    d.set_item("ground_loss", log.ground_loss)?;
    d.set_item("fps", fps)?;
    Ok(d)
}

/// Trains a run in `out` to `frames` frames in all: a new run on `levels` (or, with `init`, a
/// warm start from a checkpoint or bundled name), or with `resume=True` the run `out` holds,
/// from its last checkpoint, with its own settings. `callback(log)` is called after every
/// update with its log; returning `False` stops the run there (saved). Ctrl-C stops it after
/// the current update, saved, and raises `KeyboardInterrupt`. Returns the last update's log
/// with `checkpoint`, the run directory (what `--checkpoint` and `init` accept).
#[pyfunction]
#[pyo3(signature = (out, levels=None, frames=None, *, resume=false, model=None, hidden=None, lr=None, procs=None, frames_per_proc=None, batch_size=None, imitate=None, ground_loss=None, seed=None, init=None, eval_interval=None, eval_episodes=None, save_interval=None, callback=None))]
#[expect(
    clippy::too_many_arguments,
    reason = "the keyword arguments of the Python function"
)]
pub fn train<'py>(
    py: Python<'py>,
    out: PathBuf,
    levels: Option<Bound<'py, PyAny>>,
    frames: Option<Bound<'py, PyAny>>,
    resume: bool,
    model: Option<String>,
    hidden: Option<Bound<'py, PyAny>>,
    lr: Option<f64>,
    procs: Option<Bound<'py, PyAny>>,
    frames_per_proc: Option<Bound<'py, PyAny>>,
    batch_size: Option<Bound<'py, PyAny>>,
    imitate: Option<bool>,
    ground_loss: Option<f64>,
    seed: Option<Bound<'py, PyAny>>,
    init: Option<String>,
    eval_interval: Option<Bound<'py, PyAny>>,
    eval_episodes: Option<Bound<'py, PyAny>>,
    save_interval: Option<Bound<'py, PyAny>>,
    callback: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    // Every int is checked here, naming its argument (PyO3's own conversion raised an
    // OverflowError naming none), and the callback before anything is written.
    let frames = opt_u64_arg(frames.as_ref(), "frames")?.unwrap_or(100_000);
    let eval_interval = opt_u64_arg(eval_interval.as_ref(), "eval_interval")?;
    let eval_episodes = opt_u64_arg(eval_episodes.as_ref(), "eval_episodes")?;
    let save_interval = opt_u64_arg(save_interval.as_ref(), "save_interval")?;
    if let Some(f) = &callback
        && !f.is_callable()
    {
        return Err(PyValueError::new_err(format!(
            "callback must be callable (called with each update's log) or None, got {}",
            f.repr().map_or_else(|_| "?".into(), |r| r.to_string())
        )));
    }
    let settings = Settings {
        model,
        hidden: opt_usize_arg(hidden.as_ref(), "hidden")?,
        lr,
        procs: opt_usize_arg(procs.as_ref(), "procs")?,
        frames_per_proc: opt_usize_arg(frames_per_proc.as_ref(), "frames_per_proc")?,
        batch_size: opt_usize_arg(batch_size.as_ref(), "batch_size")?,
        imitate,
        ground_loss,
        seed: opt_u64_arg(seed.as_ref(), "seed")?,
        init,
    };
    if save_interval == Some(0) {
        return Err(PyValueError::new_err(
            "save_interval 0: must be at least 1 update",
        ));
    }
    if eval_episodes == Some(0) {
        return Err(PyValueError::new_err(
            "eval_episodes 0: must be at least 1 (eval_interval=0 turns the tracked evaluation off)",
        ));
    }
    let given = Tracking {
        eval_interval: eval_interval.unwrap_or(EVAL_INTERVAL),
        eval_episodes: eval_episodes.unwrap_or(EVAL_EPISODES),
        save_interval: Some(save_interval.unwrap_or(DEFAULT_SAVE_INTERVAL)),
    };
    let runtime = |e: anyhow::Error| match e.downcast::<HeldRun>() {
        Ok(HeldRun(dir)) => PyValueError::new_err(format!(
            "out: {} already holds a run; pass resume=True to continue it or choose another out",
            dir.display()
        )),
        Err(e) => PyRuntimeError::new_err(format!("{e:#}")),
    };
    let mut run = if resume {
        let mut refused: Vec<&str> = settings.given();
        if levels.is_some() {
            refused.insert(0, "levels");
        }
        if !refused.is_empty() {
            return Err(PyValueError::new_err(format!(
                "resume=True: the run keeps its own settings; leave out {}",
                refused.join(", ")
            )));
        }
        // Tracking left out takes the run's own.
        let check = |info: &RunInfo| {
            let saved = info.tracking.unwrap_or(given);
            Ok(Tracking {
                eval_interval: eval_interval.unwrap_or(saved.eval_interval),
                eval_episodes: eval_episodes.unwrap_or(saved.eval_episodes),
                save_interval: save_interval
                    .or(saved.save_interval)
                    .or(given.save_interval),
            })
        };
        Run::resume(&out, frames, check)
            .map_err(|e| PyValueError::new_err(format!("resume: {e:#}")))?
    } else {
        let levels = levels.ok_or_else(|| {
            PyValueError::new_err("levels: a new run needs the levels it trains on")
        })?;
        let start = settings.start(level_mix(&levels)?)?;
        let spec = RunSpec {
            start,
            frames,
            tracking: given,
        };
        Run::create(&out, spec).map_err(runtime)?
    };
    let mut last: Option<(UpdateLog, f64)> = None;
    let mut interrupted = None;
    while !run.done() {
        let p = run
            .update()
            .map_err(|e| PyRuntimeError::new_err(format!("{e:#}")))?;
        let stop = match &callback {
            Some(f) => {
                let r = f.call1((log_dict(py, &p.log, p.fps)?,));
                match r {
                    Ok(v) => v.extract::<bool>().is_ok_and(|keep| !keep),
                    Err(e) => {
                        interrupted = Some(e);
                        true
                    }
                }
            }
            None => false,
        };
        last = Some((p.log, p.fps));
        if let Err(e) = py.check_signals() {
            interrupted = Some(e);
        }
        if stop || interrupted.is_some() {
            break;
        }
    }
    let dir = run.dir().to_path_buf();
    let supervised = run.trainer().ppo.ground_loss > 0.0;
    // Saved before any exception is raised: a stop loses no update.
    let finished = run
        .finish()
        .map_err(|e| PyRuntimeError::new_err(format!("{e:#}")))?;
    if let Some(e) = interrupted {
        return Err(e);
    }
    let d = match (finished, last) {
        (Some(log), Some((_, fps))) => log_dict(py, &log, fps)?,
        (Some(log), None) => log_dict(py, &log, 0.0)?,
        // Nothing left to do (a resume past its frames): the last update the run logged,
        // with no frames per second of this call.
        (None, _) => match last_logged(&dir, supervised)? {
            Some(log) => log_dict(py, &log, 0.0)?,
            None => PyDict::new(py),
        },
    };
    d.set_item("checkpoint", dir)?;
    Ok(d)
}
