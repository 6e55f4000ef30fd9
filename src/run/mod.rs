//! A training run as one object: its directory's lock, a new start, a warm start from a
//! parent or a resume, its two logs, the tracked evaluation, its checkpoints and learning
//! curve, and the clean-up after a new run that failed before its first checkpoint.
//!
//! Whoever starts runs (the `train` command, a study's runs, the Python `train`) turns its own
//! inputs into a [`RunSpec`] — whose [`Default`] is the one list of a run's defaults — and
//! steps the [`Run`]; what it shows of the progress is its own. The run prints nothing: its
//! errors ([`RunError`]) and the differences of a resume ([`RunInfo::differences`]) name the
//! settings by the run's own names, its [`Notice`]s go to the caller, and a front end names
//! its flags or keyword arguments.
//!
//! ```text
//! Run::create(path, RunSpec) ── RunSpec::check() (nothing touched yet) ── RunDir::open(path,
//!                               fresh): lock; a fresh run's files are removed if it fails unsaved
//! Run::resume(path) ── RunDir::open ── the newest checkpoint that loads → Resumable
//!   info().differences(&RunSpec) (the caller refuses what its user gave) ── start(frames, Tracking)
//!   └─ Run::start(RunDir, RunSpec) ── logs written / checked ── Run::update()* ── Run::finish()
//! ```
//!
//! Files: `dir` ([`RunDir`]: the directory, its lock and clean-up), `checkpoints` (the
//! crash-safe generations), `spec` ([`RunSpec`], [`Start`], [`Tracking`]), `info`
//! ([`RunInfo`], [`Difference`]), `start` (a parent, the labels imitation needs), `logs`
//! (and [`LogRow`], a row as a reader of the run's progress sees it), `recipe` ([`RunRecipe`],
//! a run as data: what a study stores), `error` ([`RunError`], [`Notice`]).

mod checkpoints;
mod dir;
mod error;
mod info;
mod lock;
mod logs;
mod recipe;
mod spec;
mod start;

use std::io::Write as _;
use std::path::Path;
use std::time::Instant;

use crate::metrics::tracking::{EVAL_LOG_HEADER, TrackedEval};
use crate::policy::ppo::{LevelMix, PpoConfig, Trainer, UpdateLog};
use crate::policy::{ModelConfig, Net, Params, TrainingState};

pub use dir::{RUN_LOCK, RunDir, holds_run};
pub use error::{Notice, RunError};
pub use info::{Difference, RunInfo, model_options};
pub use logs::{LOG_HEADER, LogRow, last_row};
pub use recipe::{RunRecipe, WarmStart};
pub use spec::{DEFAULT_SAVE_INTERVAL, RunSpec, Start, Tracking};
pub use start::{Parent, absolute_teachers, check_labels, load_teachers};

/// One update's outcome, for the caller to show.
pub struct Progress {
    /// The update's log.
    pub log: UpdateLog,
    /// Frames per second since this process started the run.
    pub fps: f64,
    /// The tracked evaluation's rows, where this update ran it.
    pub evals: Vec<TrackedEval>,
}

/// Where a run's notices go ([`Run::on_notice`]).
type NoticeSink = Box<dyn FnMut(&Notice)>;

/// A training run in its locked directory ([`RunDir`]).
pub struct Run {
    dir: RunDir,
    trainer: Trainer,
    seed: u64,
    frames: u64,
    tracking: Tracking,
    /// A resumed run's progress as its checkpoint recorded it (kept where nothing is left).
    kept: Option<TrainingState>,
    log_file: std::fs::File,
    eval_file: std::fs::File,
    started: Instant,
    frames_at_start: u64,
    last: Option<UpdateLog>,
    /// The levels the bot labels too little of, for a warning ([`Self::unlabelled`]).
    unlabelled: Vec<String>,
    notices: Option<NoticeSink>,
}

impl Run {
    /// Starts the run of `spec` in `dir`: a new or warm-started run writes its logs (with the
    /// parent's rows), refusing a directory that holds a run; a resumed one keeps the rows
    /// its checkpoint holds, refusing logs that do not match it.
    pub fn start(mut dir: RunDir, spec: RunSpec) -> Result<Self, RunError> {
        let log_path = dir.path.join("log.csv");
        let eval_path = dir.path.join("eval_log.csv");
        let teachers = spec.teachers;
        let (trainer, seed, kept) = match spec.start {
            Start::Resume { trainer, info } => {
                let u = trainer.state.updates;
                // Both logs are checked before either is rewritten.
                let rows = logs::resumed_rows(&log_path, LOG_HEADER, u, true)?;
                let eval_rows = logs::resumed_rows(&eval_path, EVAL_LOG_HEADER, u, false)?;
                dir.write_log(&log_path, &format!("{LOG_HEADER}\n{rows}"))?;
                dir.write_log(&eval_path, &format!("{EVAL_LOG_HEADER}\n{eval_rows}"))?;
                (*trainer, info.seed, Some(info.training))
            }
            Start::New {
                model,
                levels,
                ppo,
                seed,
            } => {
                dir.refuse_held()?;
                let trainer = taught(new_trainer(model, levels, ppo, seed)?, &teachers)?;
                logs::write_fresh(&mut dir, None, &trainer)?;
                (trainer, seed, None)
            }
            Start::Init {
                parent,
                levels,
                ppo,
                seed,
            } => {
                dir.refuse_held()?;
                let name = parent.name.clone();
                let trainer = taught(warm_trainer(*parent, levels, ppo, seed)?, &teachers)?;
                logs::write_fresh(&mut dir, Some(&name), &trainer)?;
                (trainer, seed, None)
            }
        };
        let open_append = |path: &Path| {
            std::fs::OpenOptions::new()
                .append(true)
                .open(path)
                .map_err(RunError::io(format!("opening {}", path.display())))
        };
        Ok(Self {
            log_file: open_append(&log_path)?,
            eval_file: open_append(&eval_path)?,
            dir,
            frames_at_start: trainer.state.frames,
            trainer,
            seed,
            frames: spec.frames,
            tracking: spec.tracking,
            kept,
            started: Instant::now(),
            last: None,
            unlabelled: Vec::new(),
            notices: None,
        })
    }

    /// Checks the whole of `spec` ([`RunSpec::check`], before anything is touched), then
    /// opens the directory at `path` for a new or warm-started run and starts it
    /// ([`Start::New`] or [`Start::Init`]): refused where the directory holds a run
    /// ([`RunError::Occupied`]); what this process made there is removed if the run fails
    /// before its first checkpoint.
    pub fn create(path: &Path, spec: RunSpec) -> Result<Self, RunError> {
        let unlabelled = spec.check()?;
        let mut run = Self::start(RunDir::open(path, true)?, spec)?;
        run.unlabelled = unlabelled;
        Ok(run)
    }

    /// [`Self::create`] in a directory the caller has already locked ([`RunDir::claim`]): the
    /// whole of `spec` checked first, then the run started there.
    pub fn create_in(dir: RunDir, spec: RunSpec) -> Result<Self, RunError> {
        let unlabelled = spec.check()?;
        let mut run = Self::start(dir, spec)?;
        run.unlabelled = unlabelled;
        Ok(run)
    }

    /// Locks the run at `path` and loads its newest checkpoint that loads
    /// ([`RunError::NothingToResume`] where it holds none), for the caller to compare its
    /// settings with the run's ([`Resumable::info`]) before it goes on
    /// ([`Resumable::start`]).
    pub fn resume(path: &Path) -> Result<Resumable, RunError> {
        Self::resume_in(RunDir::open(path, false)?)
    }

    /// [`Self::resume`] in a directory the caller has already locked ([`RunDir::claim`]).
    pub fn resume_in(dir: RunDir) -> Result<Resumable, RunError> {
        let (trainer, info, skipped) = dir.load_noting()?;
        Ok(Resumable {
            dir,
            trainer,
            info,
            notices: skipped.into_iter().collect(),
        })
    }

    /// Sends the run's [`Notice`]s from now on to `sink` (without one they are dropped).
    pub fn on_notice(&mut self, sink: impl FnMut(&Notice) + 'static) {
        self.notices = Some(Box::new(sink));
    }

    /// The levels of an imitation run that the bot labels under 1% of the steps of, each
    /// with its share ([`check_labels`]): refused where it is every level, and worth a
    /// warning where others are labelled. Empty for any other run.
    pub fn unlabelled(&self) -> &[String] {
        &self.unlabelled
    }

    /// The frames the run trains to, in all.
    pub fn target_frames(&self) -> u64 {
        self.frames
    }

    /// The trainer (weights, settings, counters).
    pub fn trainer(&self) -> &Trainer {
        &self.trainer
    }

    /// The run's directory.
    pub fn dir(&self) -> &Path {
        &self.dir.path
    }

    /// Whether the run has trained its frames.
    pub fn done(&self) -> bool {
        self.trainer.state.frames >= self.frames
    }

    /// One update: its row in `log.csv`, the tracked evaluation where it falls due, and a
    /// checkpoint every save interval.
    pub fn update(&mut self) -> Result<Progress, RunError> {
        let log = self.trainer.update()?;
        let elapsed = self.started.elapsed().as_secs_f64();
        let fps = (self.trainer.state.frames - self.frames_at_start) as f64 / elapsed.max(1e-9);
        self.log_file
            .write_all(logs::update_row(&log, fps, elapsed).as_bytes())
            .map_err(RunError::io(format!(
                "writing {}",
                self.dir.path.join("log.csv").display()
            )))?;
        let t = self.tracking;
        let evals = if t.eval_interval > 0 && log.update % t.eval_interval == 0 {
            self.tracked_eval(&log)?
        } else {
            Vec::new()
        };
        if log.update % t.save_every() == 0 {
            self.save(self.training_state(Some(&log)))?;
        }
        self.last = Some(log.clone());
        Ok(Progress { log, fps, evals })
    }

    /// Ends the run: a last checkpoint (a resumed run with nothing left to do keeps its
    /// checkpoint as it is). Returns the last update's log, if any ran.
    pub fn finish(self) -> Result<Option<UpdateLog>, RunError> {
        self.finish_keeping_dir().map(|(last, _)| last)
    }

    /// [`Self::finish`], handing back the run's directory still locked: a caller with more to
    /// do in it (a study's evaluation of the run) keeps every other training out until it
    /// drops it.
    pub fn finish_keeping_dir(mut self) -> Result<(Option<UpdateLog>, RunDir), RunError> {
        if self.last.is_some() || self.kept.is_none() {
            self.save(self.training_state(self.last.as_ref()))?;
        }
        let last = self.last.take();
        Ok((last, self.dir))
    }

    /// The tracked held-out evaluation of one update: a row per level, and for a mix a row
    /// of their mean, appended to `eval_log.csv` in one write.
    fn tracked_eval(&mut self, log: &UpdateLog) -> Result<Vec<TrackedEval>, RunError> {
        let net = Net::new(self.trainer.model, self.trainer.params.detached())?;
        let mut rows = Vec::new();
        for e in self.trainer.levels.entries() {
            rows.push(crate::metrics::tracking::track(
                &net,
                &e.level,
                self.tracking.eval_episodes,
                log.update,
                log.frames,
            )?);
        }
        if self.trainer.levels.is_mix() {
            rows.extend(TrackedEval::mean_of(&rows));
        }
        let text: String = rows
            .iter()
            .map(|r| crate::table::line(&r.record()))
            .collect();
        self.eval_file
            .write_all(text.as_bytes())
            .map_err(RunError::io(format!(
                "writing {}",
                self.dir.path.join("eval_log.csv").display()
            )))?;
        Ok(rows)
    }

    /// The training state recorded with a checkpoint: `last` is the newest update's log (a
    /// run resumed with nothing left to do keeps the metrics it had).
    fn training_state(&self, last: Option<&UpdateLog>) -> TrainingState {
        let finite = |x: f64| Some(x).filter(|x| x.is_finite());
        let keep = self.kept.as_ref();
        let t = &self.trainer;
        TrainingState {
            frames: t.state.frames,
            updates: t.state.updates,
            success_rate: last.map_or_else(
                || keep.and_then(|k| k.success_rate),
                |l| finite(l.success_rate),
            ),
            mean_reward: last.map_or_else(
                || keep.and_then(|k| k.mean_reward),
                |l| finite(l.mean_reward),
            ),
            seed: self.seed,
            ground_loss: (t.ppo.ground_loss > 0.0)
                .then_some(t.ppo.ground_loss)
                .or(t.state.parent_ground_loss),
        }
    }

    /// Saves a generation and redraws the run's learning curve (a figure: its failure is a
    /// [`Notice::Curve`], not fatal, since the checkpoint is already safe).
    fn save(&mut self, training: TrainingState) -> Result<(), RunError> {
        let dir = &self.dir.path;
        checkpoints::save(&self.trainer, dir, training, self.tracking)?;
        let figure = dir.join("curve.png");
        let drawn =
            crate::metrics::figures::read_training_log(&dir.join("log.csv")).and_then(|points| {
                let curve = crate::metrics::figures::Curve {
                    label: self.trainer.model.variant.name().to_owned(),
                    points,
                };
                crate::metrics::figures::learning_curve(
                    &[curve],
                    "Mean reward during training",
                    &figure,
                )
            });
        if let Err(e) = drawn {
            self.notice(&Notice::Curve {
                path: figure,
                reason: e.to_string(),
            });
        }
        Ok(())
    }

    /// Hands `notice` to the caller's sink, if it set one.
    fn notice(&mut self, notice: &Notice) {
        if let Some(sink) = &mut self.notices {
            sink(notice);
        }
    }
}

/// A run locked and loaded for a resume ([`Run::resume`]): what it was started with, for the
/// caller to compare with its own settings, before it goes on.
pub struct Resumable {
    dir: RunDir,
    trainer: Trainer,
    info: RunInfo,
    notices: Vec<Notice>,
}

impl Resumable {
    /// What the run was started with ([`RunInfo::differences`] compares a caller's settings).
    pub fn info(&self) -> &RunInfo {
        &self.info
    }

    /// What the load has to say: a newer generation that does not load, skipped.
    pub fn notices(&self) -> &[Notice] {
        &self.notices
    }

    /// The directory.
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Goes on from the checkpoint to `frames` in all with `tracking` (checked first), the
    /// logs checked against the checkpoint before either is rewritten.
    pub fn start(self, frames: u64, tracking: Tracking) -> Result<Run, RunError> {
        tracking.check()?;
        let spec = RunSpec {
            start: Start::Resume {
                trainer: Box::new(self.trainer),
                info: Box::new(self.info),
            },
            frames,
            tracking,
            teachers: Vec::new(),
        };
        Run::start(self.dir, spec)
    }
}

/// A new run's trainer: fresh weights for `model` drawn from `seed`, with rows for all of
/// BabyAI's words where a level is BabyAI's.
fn new_trainer(
    model: ModelConfig,
    levels: LevelMix,
    ppo: PpoConfig,
    seed: u64,
) -> Result<Trainer, RunError> {
    let vocab_size = levels
        .entries()
        .iter()
        .map(|e| ModelConfig::vocab_size_for(&e.level))
        .max()
        .unwrap_or(model.vocab_size);
    let model = ModelConfig {
        vocab_size,
        ..model
    };
    let params = Params::init(&model, seed)?;
    Ok(Trainer::new(model, levels, ppo, params, seed)?)
}

/// `trainer` with `--teacher`'s networks attached (as it is without any), their file names
/// made absolute first.
fn taught(
    mut trainer: Trainer,
    teachers: &[crate::policy::ppo::TeacherSpec],
) -> Result<Trainer, RunError> {
    if teachers.is_empty() {
        return Ok(trainer);
    }
    let specs = absolute_teachers(teachers)?;
    let nets = load_teachers(&specs, &trainer.levels)?;
    trainer
        .attach_teachers(specs, nets)
        .map_err(|e| RunError::invalid("teacher", e))?;
    Ok(trainer)
}

/// A warm start's trainer on `parent`'s weights.
fn warm_trainer(
    parent: Parent,
    levels: LevelMix,
    ppo: PpoConfig,
    seed: u64,
) -> Result<Trainer, RunError> {
    let ckpt = parent.checkpoint;
    // A schedule starts from the temperature the parent was trained at.
    let mut ppo = ppo;
    if let Some(a) = &mut ppo.temperature_anneal {
        a.from = ckpt.meta.model.word_temperature.0;
    }
    let mut trainer = Trainer::warm_start(
        ckpt.meta.model,
        levels,
        ppo,
        ckpt.params,
        seed,
        ckpt.meta.training.frames,
        ckpt.meta.training.updates,
    )?;
    trainer.state.parent_ground_loss = ckpt.meta.training.ground_loss;
    Ok(trainer)
}
