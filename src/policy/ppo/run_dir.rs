//! A training run's directory and its crash-safe checkpoints.
//!
//! Each save writes one *generation*, `RUN/checkpoints/update-NNNNNNNN/` (the model pair,
//! Adam's moments, the run state and the resume settings), under a temporary name; every file
//! is flushed to disk and the directory is renamed into place in one step, so a generation
//! exists complete or not at all. The newest generation is then published as `RUN/model`
//! (itself replaced atomically, see `Checkpoint::save`) for other commands to read, and all but
//! the two newest generations are removed. `--resume` takes the newest generation that loads
//! and checks, and says so on stderr when it had to skip a newer one. Runs written before
//! generations existed (the files directly in `RUN/`) still resume.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::{PpoConfig, Trainer};
use crate::policy::checkpoint::{checkpoint_paths, write_atomic};
use crate::policy::{Checkpoint, TrainingState};
use anyhow::Context as _;
use candle_core::{Device, Tensor};
use serde::{Deserialize, Serialize};

/// Generations kept: the newest, and the one before it in case the newest is damaged later.
const KEEP_GENERATIONS: usize = 2;

/// `resume.json`: what `--resume` needs besides the weights and the optimizer tensors.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResumeFile {
    /// The run's PPO settings.
    pub ppo: PpoConfig,
    /// The run's seed.
    pub seed: u64,
    /// Adam's step count.
    pub adam_step: u64,
    /// Updates done.
    pub updates: u64,
    /// The run's held-out tracking settings (absent in runs saved before they were kept).
    #[serde(default)]
    pub tracking: Option<Tracking>,
    /// The levels of a run on several (`train --levels`); a run on one level names it in its
    /// checkpoint alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<super::LevelMix>,
}

/// The run directory's lock file: a training holds an exclusive lock on it (the system's
/// `flock`), and its pid in it; its modification time is when the training took it.
pub const RUN_LOCK: &str = ".train-lock";

/// How often, and on how many held-out episodes, a run evaluates itself (`eval_log.csv`).
/// Kept with the run so a `--resume` that leaves the flags out goes on tracking the same way.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tracking {
    /// `--eval-interval`: updates between evaluations (0: never).
    pub eval_interval: u64,
    /// `--eval-episodes`: episodes per evaluation.
    pub eval_episodes: u64,
    /// `--save-interval`: updates between checkpoints (absent in runs saved before it was
    /// kept: a resume then takes the flag's value).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub save_interval: Option<u64>,
}

/// Whether `dir` already holds a run (either layout).
pub fn holds_run(dir: &Path) -> bool {
    dir.join("resume.json").exists() || !generations(dir).is_empty()
}

fn checkpoints_dir(run: &Path) -> PathBuf {
    run.join("checkpoints")
}

/// The generation directories of `run`, oldest first.
fn generations(run: &Path) -> Vec<(u64, PathBuf)> {
    let Ok(entries) = std::fs::read_dir(checkpoints_dir(run)) else {
        return Vec::new();
    };
    let mut out: Vec<(u64, PathBuf)> = entries
        .filter_map(Result::ok)
        .filter_map(|e| {
            let name = e.file_name();
            let n = name.to_str()?.strip_prefix("update-")?.parse().ok()?;
            Some((n, e.path()))
        })
        .collect();
    out.sort();
    out
}

/// Saves the trainer as a new generation of `run` and publishes it as `RUN/model`.
pub fn save(
    trainer: &Trainer,
    run: &Path,
    training: TrainingState,
    tracking: Tracking,
) -> anyhow::Result<()> {
    let seed = training.seed;
    let parent = checkpoints_dir(run);
    std::fs::create_dir_all(&parent).with_context(|| format!("creating {}", parent.display()))?;
    // Generations being saved are this training's alone (the run lock keeps a second one
    // out); in the run directory itself, only temporary files left before this training took
    // its lock are stale: another command's output in progress there (an `eval --out` of the
    // same directory stages its report in a hidden directory) is not this process's to remove.
    remove_stale(&parent, ".saving-", None);
    let since = std::fs::metadata(run.join(RUN_LOCK)).and_then(|m| m.modified());
    if let Ok(since) = since {
        remove_stale(run, ".groundscope-", Some(since));
    }
    let tmp = tempfile::Builder::new()
        .prefix(".saving-")
        .tempdir_in(&parent)
        .with_context(|| format!("saving a checkpoint in {}", parent.display()))?;
    let mut ckpt = Checkpoint::new(
        trainer.model,
        trainer.level(),
        training,
        trainer.params.clone(),
    );
    ckpt.save(&tmp.path().join("model"))?;
    let (opt_path, _) = checkpoint_paths(&tmp.path().join("optimizer"));
    let opt: std::collections::HashMap<String, Tensor> =
        trainer.optimizer_tensors()?.into_iter().collect();
    candle_core::safetensors::save(&opt, &opt_path)
        .with_context(|| format!("writing {}", opt_path.display()))?;
    std::fs::File::open(&opt_path)
        .and_then(|f| f.sync_all())
        .with_context(|| format!("writing {}", opt_path.display()))?;
    // RNG states are u128s, which serde_json::Value cannot hold: the run state gets a file.
    write_atomic(
        &tmp.path().join("run_state.json"),
        trainer.state_json()?.as_bytes(),
    )?;
    let resume = ResumeFile {
        ppo: trainer.ppo,
        seed,
        adam_step: trainer.adam.step,
        updates: trainer.state.updates,
        tracking: Some(tracking),
        levels: trainer.levels.is_mix().then(|| trainer.levels.clone()),
    };
    write_atomic(
        &tmp.path().join("resume.json"),
        serde_json::to_string(&resume)?.as_bytes(),
    )?;
    crate::files::sync_dir(tmp.path())?;
    let dest = parent.join(format!("update-{:08}", trainer.state.updates));
    if dest.exists() {
        // The same update saved again (a run resumed from this generation): the new copy wins.
        std::fs::remove_dir_all(&dest).with_context(|| format!("replacing {}", dest.display()))?;
    }
    let kept = tmp.keep();
    if let Err(e) = std::fs::rename(&kept, &dest) {
        let _ = std::fs::remove_dir_all(&kept);
        return Err(e).with_context(|| format!("saving {}", dest.display()));
    }
    crate::files::sync_dir(&parent)?;
    ckpt.save(&run.join("model"))?;
    let gens = generations(run);
    for (_, old) in gens
        .iter()
        .take(gens.len().saturating_sub(KEEP_GENERATIONS))
    {
        let _ = std::fs::remove_dir_all(old);
    }
    // Files of the layout before generations would shadow nothing, but would mislead a reader.
    for legacy in ["resume.json", "run_state.json", "optimizer.safetensors"] {
        let _ = std::fs::remove_file(run.join(legacy));
    }
    Ok(())
}

/// Removes what a killed save left behind: entries of `dir` named `prefix…` (temporary
/// generations, temporary checkpoint files). Only one trainer writes a run, so none of them
/// is in use.
/// Removes the entries of `dir` named `prefix…`; with `before`, only the plain files last
/// written before that time (directories are left alone).
fn remove_stale(dir: &Path, prefix: &str, before: Option<std::time::SystemTime>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.filter_map(Result::ok) {
        if !e.file_name().to_string_lossy().starts_with(prefix) {
            continue;
        }
        let p = e.path();
        match before {
            None if p.is_dir() => {
                let _ = std::fs::remove_dir_all(&p);
            }
            None => {
                let _ = std::fs::remove_file(&p);
            }
            Some(t) => {
                let old = e
                    .metadata()
                    .is_ok_and(|m| m.is_file() && m.modified().is_ok_and(|m| m < t));
                if old {
                    let _ = std::fs::remove_file(&p);
                }
            }
        }
    }
}

/// What a generation holds, read and checked.
pub struct Saved {
    /// The model.
    pub ckpt: Checkpoint,
    /// The resume settings.
    pub resume: ResumeFile,
    /// The run state, as JSON for `Trainer::restore_state`.
    pub state: String,
    /// Adam's moments.
    pub optimizer: BTreeMap<String, Tensor>,
    /// Where it was read from.
    pub from: PathBuf,
}

/// Reads the generation (or legacy run directory) `dir`, checking that its parts agree.
fn read_saved(dir: &Path) -> anyhow::Result<Saved> {
    let ckpt = Checkpoint::load(&dir.join("model"))?;
    let resume_path = dir.join("resume.json");
    let text = crate::files::read_regular_to_string(&resume_path)
        .with_context(|| format!("reading {}", resume_path.display()))?;
    let resume: ResumeFile = serde_json::from_str(&text)
        .with_context(|| format!("reading {}", resume_path.display()))?;
    resume
        .ppo
        .validate()
        .with_context(|| format!("{}: ppo", resume_path.display()))?;
    if resume.updates != ckpt.meta.training.updates {
        anyhow::bail!(
            "{}: updates {} but {} is at update {}",
            resume_path.display(),
            resume.updates,
            dir.join("model.json").display(),
            ckpt.meta.training.updates
        );
    }
    let state_path = dir.join("run_state.json");
    let state = crate::files::read_regular_to_string(&state_path)
        .with_context(|| format!("reading {}", state_path.display()))?;
    let (opt_path, _) = checkpoint_paths(&dir.join("optimizer"));
    let optimizer: BTreeMap<String, Tensor> =
        candle_core::safetensors::load(&opt_path, &Device::Cpu)
            .with_context(|| format!("reading {}", opt_path.display()))?
            .into_iter()
            .collect();
    Ok(Saved {
        ckpt,
        resume,
        state,
        optimizer,
        from: dir.to_path_buf(),
    })
}

/// Builds the trainer of a saved run, checking the run state against the model.
pub fn restore(saved: Saved) -> anyhow::Result<Trainer> {
    let state_path = saved.from.join("run_state.json");
    let (opt_path, _) = checkpoint_paths(&saved.from.join("optimizer"));
    let ckpt = saved.ckpt;
    let levels = saved
        .resume
        .levels
        .clone()
        .unwrap_or_else(|| ckpt.meta.level.into());
    if levels.first() != ckpt.meta.level {
        anyhow::bail!(
            "{}: the run's first level is {}, but {} names {}",
            saved.from.join("resume.json").display(),
            levels.first(),
            saved.from.join("model.json").display(),
            ckpt.meta.level
        );
    }
    let mut trainer = Trainer::new(
        ckpt.meta.model,
        levels,
        saved.resume.ppo,
        ckpt.params,
        saved.resume.seed,
    )?;
    trainer
        .restore_state(&saved.state)
        .with_context(|| format!("reading {}", state_path.display()))?;
    let t = &ckpt.meta.training;
    if trainer.state.updates != t.updates || trainer.state.frames != t.frames {
        anyhow::bail!(
            "{}: at update {} / frame {} but the model is at update {} / frame {}",
            state_path.display(),
            trainer.state.updates,
            trainer.state.frames,
            t.updates,
            t.frames
        );
    }
    trainer
        .restore_optimizer(&saved.optimizer, saved.resume.adam_step)
        .with_context(|| format!("reading {}", opt_path.display()))?;
    Ok(trainer)
}

/// The newest saved state of `run` that loads completely, as a trainer and its seed; a newer
/// generation that does not load is reported on stderr and skipped.
pub fn load_latest(run: &Path) -> anyhow::Result<(Trainer, RunInfo)> {
    let mut candidates: Vec<PathBuf> = generations(run).into_iter().rev().map(|g| g.1).collect();
    if candidates.is_empty() {
        candidates.push(run.to_path_buf());
    }
    let mut first_error = None;
    for dir in candidates {
        match read_saved(&dir).and_then(|saved| {
            let info = RunInfo {
                seed: saved.resume.seed,
                ppo: saved.resume.ppo,
                levels: saved
                    .resume
                    .levels
                    .clone()
                    .unwrap_or_else(|| saved.ckpt.meta.level.into()),
                hidden: saved.ckpt.meta.model.lstm_hidden,
                model: saved.ckpt.meta.model,
                variant: saved.ckpt.meta.model.variant,
                training: saved.ckpt.meta.training.clone(),
                tracking: saved.resume.tracking,
            };
            restore(saved).map(|t| (t, info))
        }) {
            Ok(found) => {
                if let Some(e) = &first_error {
                    eprintln!(
                        "groundscope: resuming from {} (a newer checkpoint does not load: {e:#})",
                        dir.display()
                    );
                }
                return Ok(found);
            }
            Err(e) => {
                if first_error.is_none() {
                    first_error = Some(e);
                }
            }
        }
    }
    Err(first_error
        .unwrap_or_else(|| anyhow::anyhow!("no checkpoint"))
        .context(format!("resuming from {}", run.display())))
}

/// What a resumed run was started with.
pub struct RunInfo {
    /// Its seed.
    pub seed: u64,
    /// Its PPO settings.
    pub ppo: PpoConfig,
    /// Its levels.
    pub levels: super::LevelMix,
    /// Its hidden size.
    pub hidden: usize,
    /// Its network (sizes and model options).
    pub model: crate::policy::ModelConfig,
    /// Its model variant.
    pub variant: crate::policy::Variant,
    /// Its progress.
    pub training: TrainingState,
    /// Its tracking settings, where the run recorded them.
    pub tracking: Option<Tracking>,
}
