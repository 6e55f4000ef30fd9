//! A run's directory, locked for one training: whether it holds a run, its lock file, and the
//! clean-up after a new run that failed before its first checkpoint.

use std::path::{Path, PathBuf};

use super::checkpoints::{self, generations};
use super::{RunError, lock};
use crate::policy::checkpoint::write_atomic;
use crate::policy::ppo::Trainer;

/// The run directory's lock file: a training holds an exclusive lock on it (the system's
/// `flock`), and its pid in it; its modification time is when the training took it.
pub const RUN_LOCK: &str = ".train-lock";

/// Whether `dir` already holds a run (either layout: generations under `checkpoints/`, or the
/// files directly in the directory as runs saved before generations have them).
pub fn holds_run(dir: &Path) -> bool {
    dir.join("resume.json").exists() || !generations(dir).is_empty()
}

/// A run directory locked by this process for one training.
///
/// A fresh run's directory (`fresh`) that is dropped before the run has saved a checkpoint —
/// a failed start, an error before the first save, a panic — loses what this process made in
/// it: the logs it wrote (never one it found there), its `checkpoints/` folder if it made it,
/// its lock file, and the directory itself if it made it. A resumed run's directory is never
/// cleaned.
pub struct RunDir {
    pub(super) path: PathBuf,
    fresh: bool,
    created: bool,
    had_checkpoints: bool,
    wrote: Vec<PathBuf>,
    lock: Option<lock::RunLock>,
}

impl RunDir {
    /// Makes `path` if need be and locks it: a second training of the same directory is
    /// refused naming its process ([`RunError::Held`]). `fresh` is a new run (refused where
    /// the directory holds one, when it starts); otherwise a resume.
    pub fn open(path: &Path, fresh: bool) -> Result<Self, RunError> {
        let created = !path.exists();
        let had_checkpoints = path.join("checkpoints").exists();
        std::fs::create_dir_all(path)
            .map_err(RunError::io(format!("creating {}", path.display())))?;
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
        writable(path)?;
        dir.lock = Some(lock::lock_run(path)?);
        Ok(dir)
    }

    /// Makes `path` if need be and locks it for a run that goes on where the directory holds
    /// one and starts anew where it holds none (a study's rule), refused as [`Self::open`] is
    /// where another process holds it ([`RunError::Held`]). Which of the two it is, is decided
    /// under the lock: a holder that saved its first checkpoint just before it let go makes
    /// this a resume, not a new run refused as [`RunError::Occupied`].
    pub fn claim(path: &Path) -> Result<Self, RunError> {
        let mut dir = Self::open(path, false)?;
        dir.fresh = !dir.holds_run();
        Ok(dir)
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the directory holds a run's checkpoint (what a resume needs).
    pub fn holds_run(&self) -> bool {
        holds_run(&self.path)
    }

    /// A resume's state: the newest checkpoint of the run that loads completely, and what the
    /// run was started with, for the caller to check its own settings against
    /// ([`super::RunInfo::differences`]).
    pub fn load(&self) -> Result<(Trainer, super::RunInfo), RunError> {
        self.load_noting().map(|(trainer, info, _)| (trainer, info))
    }

    /// [`Self::load`], with the notice that a newer generation was skipped, if one was.
    pub(super) fn load_noting(
        &self,
    ) -> Result<(Trainer, super::RunInfo, Option<super::Notice>), RunError> {
        if !holds_run(&self.path) {
            // A run stopped before its first save leaves log rows and no checkpoint.
            return Err(RunError::NothingToResume(self.path.clone()));
        }
        checkpoints::load_latest(&self.path)
    }

    /// Refuses to start a new run over the one the directory holds ([`RunError::Occupied`]).
    pub(super) fn refuse_held(&self) -> Result<(), RunError> {
        if holds_run(&self.path) {
            return Err(RunError::Occupied(self.path.clone()));
        }
        Ok(())
    }

    /// Writes `text` as the log at `path`, remembering it as this process's own.
    pub(super) fn write_log(&mut self, path: &Path, text: &str) -> Result<(), RunError> {
        if self.fresh {
            self.wrote.push(path.to_path_buf());
        }
        write_atomic(path, text.as_bytes())?;
        Ok(())
    }
}

impl Drop for RunDir {
    fn drop(&mut self) {
        if !self.fresh || holds_run(&self.path) {
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
                let _ = std::fs::remove_file(self.path.join(RUN_LOCK));
            }
            drop(lock);
        }
        if self.created {
            let _ = std::fs::remove_dir(&self.path);
        }
    }
}

/// Refuses a directory this process cannot write into.
fn writable(dir: &Path) -> Result<(), RunError> {
    let probe = tempfile::NamedTempFile::new_in(dir)
        .map_err(RunError::io(format!("{} is not writable", dir.display())))?;
    drop(probe);
    Ok(())
}
