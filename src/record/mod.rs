//! Sinks that consume episode traces: Rerun (`.rrd` files, a spawned or running viewer), MCAP
//! for Foxglove / Lichtblick, and a self-contained HTML page per episode ([`html`]). They only
//! read [`EpisodeTrace`](crate::episode::EpisodeTrace)s; nothing here runs the policy.
//!
//! Files are written next to their destination under a temporary name and renamed into place
//! only when complete (footer written), so a failure or Ctrl-C leaves no partial file.

mod accuracy_lines;
pub mod fold;
pub mod html;
pub mod mcap_recorder;
pub mod rerun_recorder;
mod rrd_file;
pub mod scene;

use std::path::{Path, PathBuf};

use thiserror::Error;

pub use mcap_recorder::{McapRecorder, write_mcap};
pub use rerun_recorder::{
    RecordStats, RerunRecorder, RerunTargets, mission_words, record_rerun, word_paths,
};
pub use scene::{SCENE_BLOCK, StepScene, block_starts, scene_block, with_scene_blocks};

/// The Rerun SDK version recordings are written with (the crate is pinned to it).
pub const RERUN_SDK_VERSION: &str = "0.36.3";

/// Everything that can go wrong while recording; errors name the file or URL.
#[derive(Debug, Error)]
pub enum RecordError {
    /// Creating, writing or renaming a file failed.
    #[error("cannot write {}: {reason}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// The Rerun SDK refused (bad URL, spawn failure, ...).
    #[error("rerun: {0}")]
    Rerun(String),
    /// No viewer listens at the URL given to `--connect`.
    #[error("no Rerun viewer at {url}: {reason} (start one with `rerun`, or use --spawn / --save)")]
    NoViewer {
        /// The URL.
        url: String,
        /// Why the connection failed.
        reason: String,
    },
    /// The run was interrupted (Ctrl-C); nothing was kept.
    #[error("interrupted; no recording written")]
    Interrupted,
    /// Nothing to record.
    #[error("no episodes to record")]
    Empty,
    /// A picture could not be encoded (a PNG of the HTML page's tiles).
    #[error("cannot encode a picture: {0}")]
    Encode(String),
}

/// A recording's destination. A regular file (or a new path) is written under a temporary
/// name beside it and renamed into place by [`Self::commit`]; dropped without it, the
/// temporary file removes itself. A device or FIFO is written directly and never replaced
/// (see [`crate::files`]); a symlink is followed.
#[derive(Debug)]
pub struct PendingFile {
    tmp: Option<tempfile::TempPath>,
    /// Where the finished file goes (a symlink resolved to its target).
    target: PathBuf,
    /// The path the user gave, for messages.
    dest: PathBuf,
}

impl PendingFile {
    /// Reserves a temporary file beside `dest` (whose directory must exist and be writable),
    /// or nothing when `dest` is a special file.
    pub fn new(dest: &Path) -> Result<Self, RecordError> {
        let kind = crate::files::output_kind(dest).map_err(|e| io_err(dest, &e))?;
        let (tmp, target) = match kind {
            crate::files::OutputKind::InPlace(p) => (None, p),
            crate::files::OutputKind::Replace(target) => {
                let ext = dest.extension().and_then(|e| e.to_str()).unwrap_or("tmp");
                let tmp = crate::files::temp_file_named(
                    crate::files::parent_dir(&target),
                    &format!(".{ext}.partial"),
                )
                .map_err(|e| io_err(dest, &e))?
                .into_temp_path();
                (Some(tmp), target)
            }
        };
        Ok(Self {
            tmp,
            target,
            dest: dest.to_path_buf(),
        })
    }

    /// Where to write now.
    pub fn path(&self) -> &Path {
        self.tmp.as_deref().unwrap_or(&self.target)
    }

    /// Whether the destination is a special file written in place (no temporary file).
    pub fn in_place(&self) -> bool {
        self.tmp.is_none()
    }

    /// The destination as given.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Writes `bytes` as the whole file: into the temporary file, or into the special file
    /// itself. Named by the destination when it fails.
    pub fn write_all(&self, bytes: &[u8]) -> Result<(), RecordError> {
        use std::io::Write as _;
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .truncate(!self.in_place())
            .open(self.path())
            .map_err(|e| io_err(&self.dest, &e))?;
        f.write_all(bytes)
            .and_then(|()| f.flush())
            .map_err(|e| io_err(&self.dest, &e))
    }

    /// Flushes the finished file to disk and renames it into place.
    pub fn commit(mut self) -> Result<(), RecordError> {
        if let Some(tmp) = self.tmp.take() {
            crate::files::commit_temp(tmp, &self.target).map_err(|e| io_err(&self.dest, &e))?;
        }
        Ok(())
    }
}

/// An I/O error naming `path`.
pub(crate) fn io_err(path: &Path, e: &dyn std::fmt::Display) -> RecordError {
    RecordError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// A flag the recorders poll between steps; set by a Ctrl-C handler.
pub type StopFlag = std::sync::Arc<std::sync::atomic::AtomicBool>;

/// Whether `stop` has been raised.
pub(crate) fn stopped(stop: Option<&StopFlag>) -> bool {
    stop.is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed))
}
