//! `groundscope.train`: a training run from Python, the same [`Run`] object `groundscope train`
//! and a study's runs step — its directory, lock, resume, warm start, logs, tracked evaluation,
//! checkpoints and the clean-up after a failed start are the core's. A run made here resumes
//! with `groundscope train --resume` and the other way round.

use std::path::{Path, PathBuf};

use groundscope::policy::ppo::{
    LevelMix, MixEntry, PpoConfig, TeacherSpec, TemperatureAnneal, UpdateLog,
};
use groundscope::policy::{ModelConfig, Variant, WordTemperature};
use groundscope::run::{Parent, Run, RunError, RunInfo, RunSpec, Start, Tracking};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::env::{opt_u64_arg, parse_level, u64_arg, usize_arg};

/// The keyword arguments `train` takes besides `out`, `levels`, `frames`, `resume` and
/// `callback`: the command's flags in snake case (`--frames-per-proc`: `frames_per_proc`).
const KEYWORDS: [&str; 29] = [
    "model",
    "hidden",
    "seed",
    "init",
    "procs",
    "frames_per_proc",
    "epochs",
    "batch_size",
    "recurrence",
    "lr",
    "adam_eps",
    "discount",
    "gae_lambda",
    "entropy_coef",
    "value_loss_coef",
    "max_grad_norm",
    "clip_eps",
    "threads",
    "reward_scale",
    "normalize_advantages",
    "imitate",
    "imitate_policy_share",
    "teacher",
    "ground_loss",
    "word_temperature_anneal",
    "freeze_attention_at",
    "eval_interval",
    "eval_episodes",
    "save_interval",
];

/// The settings of a call: each keyword left out (or `None`) takes a run's default
/// ([`RunSpec::default`]); `given` names the ones given, in the call's order.
struct Settings {
    model: String,
    hidden: usize,
    seed: u64,
    init: Option<String>,
    ppo: PpoConfig,
    anneal: Option<String>,
    eval_interval: Option<u64>,
    eval_episodes: Option<u64>,
    save_interval: Option<u64>,
    teachers: Vec<TeacherSpec>,
    given: Vec<&'static str>,
}

impl Settings {
    /// The settings of the keyword arguments `kwargs`, each checked as it is read (an int out
    /// of range, a number that is not one: a `ValueError` naming it; an unknown keyword: a
    /// `TypeError`, as Python's own).
    fn of(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let d = RunSpec::default();
        let mut s = Self {
            model: d.start.model().variant.name().to_owned(),
            hidden: d.start.model().lstm_hidden,
            seed: d.start.seed(),
            init: None,
            ppo: *d.start.ppo(),
            anneal: None,
            eval_interval: None,
            eval_episodes: None,
            save_interval: None,
            teachers: Vec::new(),
            given: Vec::new(),
        };
        let Some(kwargs) = kwargs else {
            return Ok(s);
        };
        for (key, value) in kwargs.iter() {
            let key: String = key.extract()?;
            let Some(&name) = KEYWORDS.iter().find(|k| **k == key) else {
                return Err(PyTypeError::new_err(format!(
                    "train() got an unexpected keyword argument '{key}'"
                )));
            };
            if value.is_none() {
                continue;
            }
            s.set(name, &value)?;
            s.given.push(name);
        }
        Ok(s)
    }

    /// Sets the setting `name` to `v`.
    fn set(&mut self, name: &'static str, v: &Bound<'_, PyAny>) -> PyResult<()> {
        let p = &mut self.ppo;
        match name {
            "model" => self.model = text(v, name)?,
            "init" => self.init = Some(text(v, name)?),
            "word_temperature_anneal" => self.anneal = Some(text(v, name)?),
            "hidden" => self.hidden = usize_arg(v, name)?,
            "seed" => self.seed = u64_arg(v, name)?,
            "eval_interval" => self.eval_interval = Some(u64_arg(v, name)?),
            "eval_episodes" => self.eval_episodes = Some(u64_arg(v, name)?),
            "save_interval" => self.save_interval = Some(u64_arg(v, name)?),
            "freeze_attention_at" => p.freeze_attention_at = Some(u64_arg(v, name)?),
            "procs" => p.procs = usize_arg(v, name)?,
            "frames_per_proc" => p.frames_per_proc = usize_arg(v, name)?,
            "epochs" => p.epochs = usize_arg(v, name)?,
            "batch_size" => p.batch_size = usize_arg(v, name)?,
            "recurrence" => p.recurrence = usize_arg(v, name)?,
            "threads" => p.threads = usize_arg(v, name)?,
            "lr" => p.lr = number(v, name)?,
            "adam_eps" => p.adam_eps = number(v, name)?,
            "discount" => p.discount = number(v, name)?,
            "gae_lambda" => p.gae_lambda = number(v, name)?,
            "entropy_coef" => p.entropy_coef = number(v, name)?,
            "value_loss_coef" => p.value_loss_coef = number(v, name)?,
            "max_grad_norm" => p.max_grad_norm = number(v, name)?,
            "clip_eps" => p.clip_eps = number(v, name)?,
            "reward_scale" => p.reward_scale = number(v, name)?,
            "imitate_policy_share" => p.imitate_policy_share = number(v, name)?,
            "ground_loss" => p.ground_loss = number(v, name)?,
            "normalize_advantages" => p.normalize_advantages = flag(v, name)?,
            "imitate" => p.imitate = flag(v, name)?,
            "teacher" => {
                // One teacher as a str, several as a list of str (`train --teacher`'s values).
                let items: Vec<String> = match v.extract::<String>() {
                    Ok(one) => vec![one],
                    Err(_) => v.extract().map_err(|_| {
                        PyValueError::new_err(format!(
                            "teacher must be a str or a list of str ([ID=]CHECKPOINT), got {}",
                            repr(v)
                        ))
                    })?,
                };
                self.teachers = items
                    .iter()
                    .map(|t| {
                        TeacherSpec::parse(t).map_err(|e| PyValueError::new_err(e.to_string()))
                    })
                    .collect::<PyResult<_>>()?;
            }
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "train() got an unexpected keyword argument '{name}'"
                )));
            }
        }
        Ok(())
    }

    /// Whether keyword `name` was given.
    fn gave(&self, name: &str) -> bool {
        self.given.contains(&name)
    }

    /// The network `model` and `hidden` name (a new run's).
    fn model(&self) -> PyResult<ModelConfig> {
        let variant = Variant::parse(&self.model).ok_or_else(|| {
            PyValueError::new_err(format!(
                "model {:?} is not attention or baseline",
                self.model
            ))
        })?;
        Ok(ModelConfig {
            lstm_hidden: self.hidden,
            gru_hidden: self.hidden,
            ..ModelConfig::new(variant)
        })
    }

    /// The PPO settings, a `word_temperature_anneal` schedule starting at `from` (the model's
    /// word temperature).
    fn ppo(&self, from: f32) -> PyResult<PpoConfig> {
        let mut ppo = self.ppo;
        if let Some(s) = &self.anneal {
            ppo.temperature_anneal = Some(
                TemperatureAnneal::parse(s, from, WordTemperature::PAPER.0)
                    .map_err(|e| PyValueError::new_err(format!("word_temperature_anneal: {e}")))?,
            );
        }
        Ok(ppo)
    }

    /// The tracking: the keywords given, the run's own (`saved`, on resume) for those left
    /// out, and the defaults for what neither says.
    fn tracking(&self, saved: Option<Tracking>) -> Tracking {
        let d = RunSpec::default().tracking;
        let saved = saved.unwrap_or(d);
        Tracking {
            eval_interval: self.eval_interval.unwrap_or(saved.eval_interval),
            eval_episodes: self.eval_episodes.unwrap_or(saved.eval_episodes),
            save_interval: self
                .save_interval
                .or(saved.save_interval)
                .or(d.save_interval),
        }
    }

    /// A new or warm-started run's start on `levels` (a parent that cannot be loaded refused
    /// naming `init`; the rest is checked by the run before its directory is made).
    fn start(&self, levels: LevelMix) -> PyResult<Start> {
        let model = self.model()?;
        let Some(name) = &self.init else {
            return Ok(Start::New {
                ppo: self.ppo(model.word_temperature.0)?,
                model,
                levels,
                seed: self.seed,
            });
        };
        if self.gave("model") || self.gave("hidden") {
            return Err(PyValueError::new_err(
                "init: a warm start keeps its parent's network; leave out model and hidden",
            ));
        }
        let parent = Parent::load(name).map_err(|e| match e {
            e @ (RunError::BotParent | RunError::Invalid { .. }) => refusal(e, false),
            e => PyValueError::new_err(format!("init {name}: {e}")),
        })?;
        Ok(Start::Init {
            ppo: self.ppo(parent.checkpoint.meta.model.word_temperature.0)?,
            parent: Box::new(parent),
            levels,
            seed: self.seed,
        })
    }

    /// `resume=True`: refuses a keyword given with a value other than the run's (`info`; the
    /// levels when `levels` is given), naming it; the others keep the run's values.
    fn check_resume(&self, info: &RunInfo, levels: Option<LevelMix>, dir: &Path) -> PyResult<()> {
        let levels_given = levels.is_some();
        let spec = RunSpec {
            start: Start::New {
                model: self.model()?,
                levels: levels.unwrap_or_else(|| info.levels.clone()),
                ppo: self.ppo(info.model.word_temperature.0)?,
                seed: self.seed,
            },
            ..RunSpec::default()
        };
        for d in info.differences(&spec) {
            let Some(kw) = keyword(d.field) else {
                continue;
            };
            if self.gave(kw) || (kw == "levels" && levels_given) {
                return Err(PyValueError::new_err(format!(
                    "resume=True: the run in {} was started with {kw}={}, not {kw}={}; leave out {kw} to keep the run's value",
                    dir.display(),
                    d.stored,
                    d.given
                )));
            }
        }
        Ok(())
    }
}

/// A str keyword argument.
fn text(v: &Bound<'_, PyAny>, name: &str) -> PyResult<String> {
    v.extract()
        .map_err(|_| PyValueError::new_err(format!("{name} must be a str, got {}", repr(v))))
}

/// A number keyword argument (an int or a float).
fn number(v: &Bound<'_, PyAny>, name: &str) -> PyResult<f64> {
    v.extract()
        .map_err(|_| PyValueError::new_err(format!("{name} must be a number, got {}", repr(v))))
}

/// A bool keyword argument.
fn flag(v: &Bound<'_, PyAny>, name: &str) -> PyResult<bool> {
    v.extract().map_err(|_| {
        PyValueError::new_err(format!("{name} must be True or False, got {}", repr(v)))
    })
}

/// `v` as Python shows it.
fn repr(v: &Bound<'_, PyAny>) -> String {
    v.repr().map_or_else(|_| "?".into(), |r| r.to_string())
}

/// The keyword argument that gives a run's setting `field` ([`RunInfo::differences`]'s and
/// [`RunError::Invalid`]'s names), where `train` takes one; the network's and PPO's own
/// checks (`model`, `ppo`) name their setting in their reason.
fn keyword(field: &'static str) -> Option<&'static str> {
    match field {
        "variant" => Some("model"),
        "temperature_anneal" => Some("word_temperature_anneal"),
        "levels" | "room_size" | "n_objects" | "tasks" | "done_required" | "color_optional" => {
            Some("levels")
        }
        "model" | "ppo" => None,
        field => KEYWORDS.iter().copied().find(|k| *k == field),
    }
}

/// The run's error as `train` raises it: bad input (the caller's settings, a directory that
/// holds a run, a log that does not match a resumed run's checkpoint) is a `ValueError` naming
/// its keyword argument; on a resume every error is (`resume`), as a new run's other errors
/// are `RuntimeError`s.
fn refusal(e: RunError, resume: bool) -> PyErr {
    match e {
        RunError::Occupied(dir) => PyValueError::new_err(format!(
            "out: {} already holds a run; pass resume=True to continue it or choose another out",
            dir.display()
        )),
        RunError::NothingToResume(dir) => PyValueError::new_err(format!(
            "resume: {} holds no checkpoint to resume (a run stopped before its first save); start it again without resume=True",
            dir.display()
        )),
        RunError::BadLog { what, .. } => PyValueError::new_err(format!(
            "resume: {what}; restore it, or start a new run from this one's weights with init"
        )),
        RunError::BotParent => PyValueError::new_err(
            "init bot: the bot is a planner with no network weights to start from; to learn from it, pass imitate=True",
        ),
        RunError::Invalid { field, reason } => match keyword(field) {
            Some(kw) => PyValueError::new_err(format!("{kw}: {reason}")),
            None => PyValueError::new_err(reason),
        },
        e if resume => PyValueError::new_err(format!("resume: {e}")),
        e => PyRuntimeError::new_err(e.to_string()),
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

/// Trains a run in `out` to `frames` frames in all (by default a run's, [`RunSpec::default`]):
/// a new run on `levels` (or, with `init`, a warm start from a checkpoint or bundled name), or
/// with `resume=True` the run `out` holds, from its last checkpoint, with its own settings (a
/// keyword given with another value is refused naming it). The settings are the keyword
/// arguments of [`KEYWORDS`], `train`'s flags in snake case, each a run's default when left
/// out. `callback(log)` is called after every update with its log; returning `False` stops
/// the run there (saved). Ctrl-C stops it after the current update, saved, and raises
/// `KeyboardInterrupt`. Returns the last update's log with `checkpoint`, the run directory
/// (what `--checkpoint` and `init` accept).
#[pyfunction]
#[pyo3(signature = (out, levels=None, frames=None, *, resume=false, callback=None, **settings))]
pub fn train<'py>(
    py: Python<'py>,
    out: PathBuf,
    levels: Option<Bound<'py, PyAny>>,
    frames: Option<Bound<'py, PyAny>>,
    resume: bool,
    callback: Option<Bound<'py, PyAny>>,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    // Every int is checked here, naming its argument (PyO3's own conversion raised an
    // OverflowError naming none), and the callback before anything is written.
    let frames = opt_u64_arg(frames.as_ref(), "frames")?.unwrap_or(RunSpec::default().frames);
    let settings = Settings::of(settings)?;
    if let Some(f) = &callback
        && !f.is_callable()
    {
        return Err(PyValueError::new_err(format!(
            "callback must be callable (called with each update's log) or None, got {}",
            repr(f)
        )));
    }
    let levels = levels.as_ref().map(level_mix).transpose()?;
    let mut run = if resume {
        if settings.gave("init") {
            return Err(PyValueError::new_err(
                "resume=True: init starts a new run from a checkpoint's weights; leave out init",
            ));
        }
        if settings.gave("teacher") {
            return Err(PyValueError::new_err(
                "resume=True: a resumed run keeps the teachers it was started with; leave out teacher",
            ));
        }
        let resumable = Run::resume(&out).map_err(|e| refusal(e, true))?;
        for n in resumable.notices() {
            eprintln!("groundscope: {n}");
        }
        let info = resumable.info();
        settings.check_resume(info, levels, &out)?;
        // Tracking left out takes the run's own.
        let tracking = settings.tracking(info.tracking);
        resumable
            .start(frames, tracking)
            .map_err(|e| refusal(e, true))?
    } else {
        let levels = levels.ok_or_else(|| {
            PyValueError::new_err("levels: a new run needs the levels it trains on")
        })?;
        let spec = RunSpec {
            start: settings.start(levels)?,
            frames,
            tracking: settings.tracking(None),
            teachers: settings.teachers.clone(),
        };
        // The run checks the whole of it (imitation's labels included) before it makes its
        // directory.
        let run = Run::create(&out, spec).map_err(|e| refusal(e, false))?;
        for what in run.unlabelled() {
            eprintln!(
                "groundscope: warning: imitate: the bot labels almost nothing of {what}: its episodes give imitation no labels"
            );
        }
        run
    };
    run.on_notice(|n| eprintln!("groundscope: {n}"));
    let mut last: Option<(UpdateLog, f64)> = None;
    let mut interrupted = None;
    while !run.done() {
        let p = run
            .update()
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
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
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
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
