//! A training run as one object: its directory's lock, a new start, a warm start from a
//! parent or a resume, its two logs, the tracked evaluation, its checkpoints and learning
//! curve, and the clean-up after a new run that failed before its first checkpoint.
//!
//! Whoever starts runs (the `train` command, a study's runs, a Python `train`) turns its own
//! inputs into a [`RunSpec`] ([`Run::create`]) or a check of a run's own settings
//! ([`Run::resume`]), and steps the [`Run`];
//! what it shows of the progress is its own. The run names its fields in errors; a caller
//! that took them from flags names the flags.
//!
//! ```text
//! Run::create(path, RunSpec) ── RunDir::open(path, fresh) ── lock; a fresh run's files are
//!                                                            removed if it fails unsaved
//! Run::resume(path, frames, check) ── RunDir::open ── RunDir::load() (the newest checkpoint
//!                                     that loads) ── check(RunInfo) → Tracking
//!   └─ Run::start(RunDir, RunSpec) ── logs written / checked ── Run::update()* ── Run::finish()
//! ```

mod lock;
mod logs;
mod start;

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;

use crate::metrics::tracking::{EVAL_LOG_HEADER, TrackedEval};
use crate::policy::checkpoint::write_atomic;
use crate::policy::ppo::run_dir::{self, RunInfo, Tracking};
use crate::policy::ppo::{LevelMix, PpoConfig, Trainer, UpdateLog};
use crate::policy::{ModelConfig, Net, Params, TrainingState};

pub use logs::LOG_HEADER;
pub use start::{Parent, check_labels};

/// A run directory locked by this process for one training.
///
/// A fresh run's directory (`fresh`) that is dropped before the run has saved a checkpoint —
/// a failed start, an error before the first save, a panic — loses what this process made in
/// it: the logs it wrote (never one it found there), its `checkpoints/` folder if it made it,
/// its lock file, and the directory itself if it made it. A resumed run's directory is never
/// cleaned.
pub struct RunDir {
    path: PathBuf,
    fresh: bool,
    created: bool,
    had_checkpoints: bool,
    wrote: Vec<PathBuf>,
    lock: Option<lock::RunLock>,
}

impl RunDir {
    /// Makes `path` if need be and locks it: a second training of the same directory is
    /// refused naming its process. `fresh` is a new run (refused where the directory holds
    /// one, when it starts); otherwise a resume.
    pub fn open(path: &Path, fresh: bool) -> anyhow::Result<Self> {
        let created = !path.exists();
        let had_checkpoints = path.join("checkpoints").exists();
        std::fs::create_dir_all(path).with_context(|| format!("creating {}", path.display()))?;
        let mut dir = Self {
            path: path.to_path_buf(),
            fresh,
            created,
            had_checkpoints,
            wrote: Vec::new(),
            lock: None,
        };
        // Held until the run ends (the system releases it if the process dies). A training
        // refused here touches nothing: the directory and its files are the holder's.
        dir.lock = Some(writable(path).and_then(|()| lock::lock_run(path))?);
        Ok(dir)
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the directory holds a run's checkpoint (what a resume needs).
    pub fn holds_run(&self) -> bool {
        run_dir::holds_run(&self.path)
    }

    /// A resume's state: the newest checkpoint of the run that loads completely, and what the
    /// run was started with, for the caller to check its own settings against.
    pub fn load(&self) -> anyhow::Result<(Trainer, RunInfo)> {
        if !run_dir::holds_run(&self.path) {
            // A run stopped before its first save leaves log rows and no checkpoint.
            return Err(NothingToResume(self.path.clone()).into());
        }
        run_dir::load_latest(&self.path)
    }

    /// Refuses to start a new run over the one the directory holds ([`HeldRun`]).
    fn refuse_held(&self) -> anyhow::Result<()> {
        if run_dir::holds_run(&self.path) {
            return Err(HeldRun(self.path.clone()).into());
        }
        Ok(())
    }

    /// A new run's two logs: their headers, and a warm start's parent's rows up to its
    /// update, so its log and learning curve start at frame 0.
    fn write_fresh_logs(&mut self, parent: Option<&str>, trainer: &Trainer) -> anyhow::Result<()> {
        let u = trainer.state.updates;
        let rows = |file: &str, header: &str| {
            parent.map_or_else(String::new, |name| logs::parent_rows(name, file, header, u))
        };
        let (log, evals) = (
            rows("log.csv", LOG_HEADER),
            rows("eval_log.csv", EVAL_LOG_HEADER),
        );
        self.write_log(&self.path.join("log.csv"), &format!("{LOG_HEADER}\n{log}"))?;
        self.write_log(
            &self.path.join("eval_log.csv"),
            &format!("{EVAL_LOG_HEADER}\n{evals}"),
        )
    }

    /// Writes `text` as the log at `path`, remembering it as this process's own.
    fn write_log(&mut self, path: &Path, text: &str) -> anyhow::Result<()> {
        if self.fresh {
            self.wrote.push(path.to_path_buf());
        }
        write_atomic(path, text.as_bytes())?;
        Ok(())
    }
}

impl Drop for RunDir {
    fn drop(&mut self) {
        if !self.fresh || run_dir::holds_run(&self.path) {
            return;
        }
        for f in &self.wrote {
            let _ = std::fs::remove_file(f);
        }
        if !self.had_checkpoints {
            let _ = std::fs::remove_dir(self.path.join("checkpoints"));
        }
        if let Some(lock) = self.lock.take() {
            if lock.created {
                let _ = std::fs::remove_file(self.path.join(lock::RUN_LOCK));
            }
            drop(lock);
        }
        if self.created {
            let _ = std::fs::remove_dir(&self.path);
        }
    }
}

/// Refuses a directory this process cannot write into.
fn writable(dir: &Path) -> anyhow::Result<()> {
    let probe = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("{} is not writable", dir.display()))?;
    drop(probe);
    Ok(())
}

/// A new run refused because its directory already holds one: a caller that can resume names
/// how (`train` names `--resume`).
#[derive(Debug, thiserror::Error)]
#[error("{} already holds a run; resume it or choose another run directory", .0.display())]
pub struct HeldRun(pub PathBuf);

/// A resume refused because the directory holds no checkpoint (a run stopped before its
/// first save): a caller names how to start it anew (`train`: without `--resume`).
#[derive(Debug, thiserror::Error)]
#[error(
    "{} holds no checkpoint to resume (a run stopped before its first save); start it again as a new run",
    .0.display()
)]
pub struct NothingToResume(pub PathBuf);

/// How a run begins.
pub enum Start {
    /// New weights for `model`, drawn from `seed`. A model for a BabyAI level gets rows for
    /// all of BabyAI's words.
    New {
        /// The network.
        model: ModelConfig,
        /// The levels trained on.
        levels: LevelMix,
        /// The PPO (or imitation) settings.
        ppo: PpoConfig,
        /// The seed of the weights and of the run's streams.
        seed: u64,
    },
    /// A parent's weights, with fresh Adam moments and streams; the frame and update counts
    /// continue the parent's, and so do its logs' rows where they sit beside it.
    Init {
        /// The parent ([`Parent::load`]).
        parent: Box<Parent>,
        /// The levels trained on.
        levels: LevelMix,
        /// The PPO settings.
        ppo: PpoConfig,
        /// The seed of the run's streams.
        seed: u64,
    },
    /// The run in the directory, exactly where its checkpoint left it ([`RunDir::load`]).
    Resume {
        /// Its trainer.
        trainer: Box<Trainer>,
        /// What it was started with.
        info: Box<RunInfo>,
    },
}

/// What a run does from its start.
pub struct RunSpec {
    /// How it begins.
    pub start: Start,
    /// Train until this many frames in total (a resumed or warm-started run counts its
    /// earlier frames).
    pub frames: u64,
    /// The tracked evaluation and the checkpoint interval.
    pub tracking: Tracking,
}

/// One update's outcome, for the caller to show.
pub struct Progress {
    /// The update's log.
    pub log: UpdateLog,
    /// Frames per second since this process started the run.
    pub fps: f64,
    /// The tracked evaluation's rows, where this update ran it.
    pub evals: Vec<TrackedEval>,
}

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
}

impl Run {
    /// Starts the run of `spec` in `dir`: a new or warm-started run writes its logs (with the
    /// parent's rows), refusing a directory that holds a run; a resumed one keeps the rows
    /// its checkpoint holds, refusing logs that do not match it.
    pub fn start(mut dir: RunDir, spec: RunSpec) -> anyhow::Result<Self> {
        let log_path = dir.path.join("log.csv");
        let eval_path = dir.path.join("eval_log.csv");
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
                let trainer = new_trainer(model, levels, ppo, seed)?;
                dir.write_fresh_logs(None, &trainer)?;
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
                let trainer = warm_trainer(*parent, levels, ppo, seed)?;
                dir.write_fresh_logs(Some(&name), &trainer)?;
                (trainer, seed, None)
            }
        };
        let open_append = |path: &Path| {
            std::fs::OpenOptions::new()
                .append(true)
                .open(path)
                .with_context(|| format!("opening {}", path.display()))
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
        })
    }

    /// Opens the directory at `path` for a new or warm-started run and starts it ([`Start::New`]
    /// or [`Start::Init`]): refused where the directory holds a run; what this process made
    /// there is removed if the run fails before its first checkpoint.
    pub fn create(path: &Path, spec: RunSpec) -> anyhow::Result<Self> {
        Self::start(RunDir::open(path, true)?, spec)
    }

    /// Resumes the run at `path` from its newest checkpoint that loads, to `frames` in all.
    /// Once the directory is locked and loaded, `check` sees what the run was started with —
    /// to refuse settings of its caller's that contradict it — and returns the tracking to
    /// go on with.
    pub fn resume(
        path: &Path,
        frames: u64,
        check: impl FnOnce(&RunInfo) -> anyhow::Result<Tracking>,
    ) -> anyhow::Result<Self> {
        let dir = RunDir::open(path, false)?;
        let (trainer, info) = dir.load()?;
        let tracking = check(&info)?;
        let spec = RunSpec {
            start: Start::Resume {
                trainer: Box::new(trainer),
                info: Box::new(info),
            },
            frames,
            tracking,
        };
        Self::start(dir, spec)
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
    pub fn update(&mut self) -> anyhow::Result<Progress> {
        let log = self.trainer.update()?;
        let elapsed = self.started.elapsed().as_secs_f64();
        let fps = (self.trainer.state.frames - self.frames_at_start) as f64 / elapsed.max(1e-9);
        self.log_file
            .write_all(logs::update_row(&log, fps, elapsed).as_bytes())?;
        let t = self.tracking;
        let evals = if t.eval_interval > 0 && log.update % t.eval_interval == 0 {
            self.tracked_eval(&log)?
        } else {
            Vec::new()
        };
        if log.update % t.save_interval.unwrap_or(DEFAULT_SAVE_INTERVAL) == 0 {
            self.save(self.training_state(Some(&log)))?;
        }
        self.last = Some(log.clone());
        Ok(Progress { log, fps, evals })
    }

    /// Ends the run: a last checkpoint (a resumed run with nothing left to do keeps its
    /// checkpoint as it is). Returns the last update's log, if any ran.
    pub fn finish(self) -> anyhow::Result<Option<UpdateLog>> {
        if self.last.is_some() || self.kept.is_none() {
            self.save(self.training_state(self.last.as_ref()))?;
        }
        Ok(self.last)
    }

    /// The tracked held-out evaluation of one update: a row per level, and for a mix a row
    /// of their mean, appended to `eval_log.csv` in one write.
    fn tracked_eval(&mut self, log: &UpdateLog) -> anyhow::Result<Vec<TrackedEval>> {
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
        self.eval_file.write_all(text.as_bytes())?;
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

    /// Saves a generation and redraws the run's learning curve (a figure: its failure is
    /// reported on stderr, not fatal, since the checkpoint is already safe).
    fn save(&self, training: TrainingState) -> anyhow::Result<()> {
        let dir = &self.dir.path;
        run_dir::save(&self.trainer, dir, training, self.tracking)?;
        let drawn = crate::metrics::figures::read_training_log(&dir.join("log.csv"))
            .map_err(anyhow::Error::from)
            .and_then(|points| {
                let curve = crate::metrics::figures::Curve {
                    label: self.trainer.model.variant.name().to_owned(),
                    points,
                };
                crate::metrics::figures::learning_curve(
                    &[curve],
                    "Mean reward during training",
                    &dir.join("curve.png"),
                )
                .map_err(anyhow::Error::from)
            });
        if let Err(e) = drawn {
            eprintln!("groundscope: {}: {e:#}", dir.join("curve.png").display());
        }
        Ok(())
    }
}

/// The checkpoint interval by default (`train --save-interval`), and of a run that recorded
/// none (saved before it was kept).
pub const DEFAULT_SAVE_INTERVAL: u64 = 10;

/// A new run's trainer: fresh weights for `model` drawn from `seed`, with rows for all of
/// BabyAI's words where a level is BabyAI's.
fn new_trainer(
    model: ModelConfig,
    levels: LevelMix,
    ppo: PpoConfig,
    seed: u64,
) -> anyhow::Result<Trainer> {
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

/// A warm start's trainer on `parent`'s weights.
fn warm_trainer(
    parent: Parent,
    levels: LevelMix,
    ppo: PpoConfig,
    seed: u64,
) -> anyhow::Result<Trainer> {
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
