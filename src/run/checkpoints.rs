//! A run's crash-safe checkpoints.
//!
//! Each save writes one *generation*, `RUN/checkpoints/update-NNNNNNNN/` (the model pair,
//! Adam's moments, the run state and the resume settings), under a temporary name; every file
//! is flushed to disk and the directory is renamed into place in one step, so a generation
//! exists complete or not at all. The newest generation is then published as `RUN/model`
//! (itself replaced atomically, see `Checkpoint::save`) for other commands to read, and all but
//! the two newest generations are removed. A resume takes the newest generation that loads
//! and checks, with a [`Notice::Skipped`] when it had to skip a newer one. Runs written before
//! generations existed (the files directly in `RUN/`) still resume.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::dir::RUN_LOCK;
use super::{Notice, RunError, RunInfo, Tracking};
use crate::policy::checkpoint::{checkpoint_paths, write_atomic};
use crate::policy::ppo::{LevelMix, PpoConfig, Trainer};
use crate::policy::{Checkpoint, TrainingState};
use candle_core::{Device, Tensor};
use serde::{Deserialize, Serialize};

/// Generations kept: the newest, and the one before it in case the newest is damaged later.
const KEEP_GENERATIONS: usize = 2;

/// `resume.json`: what a resume needs besides the weights and the optimizer tensors.
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
    pub levels: Option<LevelMix>,
}

fn checkpoints_dir(run: &Path) -> PathBuf {
    run.join("checkpoints")
}

/// The generation directories of `run`, oldest first.
pub(super) fn generations(run: &Path) -> Vec<(u64, PathBuf)> {
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
pub(super) fn save(
    trainer: &Trainer,
    run: &Path,
    training: TrainingState,
    tracking: Tracking,
) -> Result<(), RunError> {
    let seed = training.seed;
    let parent = checkpoints_dir(run);
    std::fs::create_dir_all(&parent)
        .map_err(RunError::io(format!("creating {}", parent.display())))?;
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
        .map_err(RunError::io(format!(
            "saving a checkpoint in {}",
            parent.display()
        )))?;
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
    candle_core::safetensors::save(&opt, &opt_path).map_err(|e| RunError::Damaged {
        path: opt_path.clone(),
        reason: format!("cannot be written: {e}"),
    })?;
    std::fs::File::open(&opt_path)
        .and_then(|f| f.sync_all())
        .map_err(RunError::io(format!("writing {}", opt_path.display())))?;
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
    let json = serde_json::to_string(&resume).map_err(|e| RunError::Damaged {
        path: tmp.path().join("resume.json"),
        reason: format!("cannot be written: {e}"),
    })?;
    write_atomic(&tmp.path().join("resume.json"), json.as_bytes())?;
    crate::files::sync_dir(tmp.path())
        .map_err(RunError::io(format!("saving {}", tmp.path().display())))?;
    let dest = parent.join(format!("update-{:08}", trainer.state.updates));
    if dest.exists() {
        // The same update saved again (a run resumed from this generation): the new copy wins.
        std::fs::remove_dir_all(&dest)
            .map_err(RunError::io(format!("replacing {}", dest.display())))?;
    }
    let kept = tmp.keep();
    if let Err(e) = std::fs::rename(&kept, &dest) {
        let _ = std::fs::remove_dir_all(&kept);
        return Err(RunError::io(format!("saving {}", dest.display()))(e));
    }
    crate::files::sync_dir(&parent)
        .map_err(RunError::io(format!("saving {}", parent.display())))?;
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
struct Saved {
    /// The model.
    ckpt: Checkpoint,
    /// The resume settings.
    resume: ResumeFile,
    /// The run state, as JSON for `Trainer::restore_state`.
    state: String,
    /// Adam's moments.
    optimizer: BTreeMap<String, Tensor>,
    /// Where it was read from.
    from: PathBuf,
}

/// Reads the generation (or legacy run directory) `dir`, checking that its parts agree.
fn read_saved(dir: &Path) -> Result<Saved, RunError> {
    let ckpt = Checkpoint::load(&dir.join("model"))?;
    let resume_path = dir.join("resume.json");
    let text = crate::files::read_regular_to_string(&resume_path)
        .map_err(RunError::io(format!("reading {}", resume_path.display())))?;
    let damaged = |reason: String| RunError::Damaged {
        path: resume_path.clone(),
        reason,
    };
    let resume: ResumeFile = serde_json::from_str(&text).map_err(|e| damaged(e.to_string()))?;
    resume
        .ppo
        .validate()
        .map_err(|e| damaged(format!("ppo: {e}")))?;
    if resume.updates != ckpt.meta.training.updates {
        return Err(damaged(format!(
            "updates {} but {} is at update {}",
            resume.updates,
            dir.join("model.json").display(),
            ckpt.meta.training.updates
        )));
    }
    let state_path = dir.join("run_state.json");
    let state = crate::files::read_regular_to_string(&state_path)
        .map_err(RunError::io(format!("reading {}", state_path.display())))?;
    let (opt_path, _) = checkpoint_paths(&dir.join("optimizer"));
    let optimizer: BTreeMap<String, Tensor> =
        candle_core::safetensors::load(&opt_path, &Device::Cpu)
            .map_err(|e| RunError::Damaged {
                path: opt_path.clone(),
                reason: e.to_string(),
            })?
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
fn restore(saved: Saved) -> Result<Trainer, RunError> {
    let state_path = saved.from.join("run_state.json");
    let (opt_path, _) = checkpoint_paths(&saved.from.join("optimizer"));
    let ckpt = saved.ckpt;
    let levels = saved
        .resume
        .levels
        .clone()
        .unwrap_or_else(|| ckpt.meta.level.into());
    if levels.first() != ckpt.meta.level {
        return Err(RunError::Damaged {
            path: saved.from.join("resume.json"),
            reason: format!(
                "the run's first level is {}, but {} names {}",
                levels.first(),
                saved.from.join("model.json").display(),
                ckpt.meta.level
            ),
        });
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
        .map_err(|e| RunError::Damaged {
            path: state_path.clone(),
            reason: e.to_string(),
        })?;
    let teachers = trainer.teacher_specs().to_vec();
    if !teachers.is_empty() {
        let nets = super::load_teachers(&teachers, &trainer.levels)?;
        trainer
            .attach_teachers(teachers, nets)
            .map_err(|e| RunError::Damaged {
                path: state_path.clone(),
                reason: e.to_string(),
            })?;
    }
    let t = &ckpt.meta.training;
    if trainer.state.updates != t.updates || trainer.state.frames != t.frames {
        return Err(RunError::Damaged {
            path: state_path,
            reason: format!(
                "at update {} / frame {} but the model is at update {} / frame {}",
                trainer.state.updates, trainer.state.frames, t.updates, t.frames
            ),
        });
    }
    trainer
        .restore_optimizer(&saved.optimizer, saved.resume.adam_step)
        .map_err(|e| RunError::Damaged {
            path: opt_path,
            reason: e.to_string(),
        })?;
    Ok(trainer)
}

/// The newest saved state of `run` that loads completely, as a trainer and what the run was
/// started with; a newer generation that does not load is skipped, with a notice saying so.
pub(super) fn load_latest(run: &Path) -> Result<(Trainer, RunInfo, Option<Notice>), RunError> {
    let mut candidates: Vec<PathBuf> = generations(run).into_iter().rev().map(|g| g.1).collect();
    if candidates.is_empty() {
        candidates.push(run.to_path_buf());
    }
    let mut first_error: Option<RunError> = None;
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
            Ok((trainer, info)) => {
                let skipped = first_error.map(|e| Notice::Skipped {
                    from: dir.clone(),
                    reason: e.to_string(),
                });
                return Ok((trainer, info, skipped));
            }
            Err(e) => {
                if first_error.is_none() {
                    first_error = Some(e);
                }
            }
        }
    }
    // The newest generation's error names its file.
    Err(first_error.unwrap_or_else(|| RunError::Damaged {
        path: run.to_path_buf(),
        reason: "no checkpoint".to_owned(),
    }))
}
