//! The run directory's lock: one training at a time writes a run directory.

use std::path::Path;

use super::RunError;
use super::dir::RUN_LOCK;

/// A held lock on a run directory ([`lock_run`]).
pub(super) struct RunLock {
    /// The lock file, locked (the system releases it when it is closed or the process dies).
    _file: std::fs::File,
    /// Whether this process made the lock file (a new run that fails removes it).
    pub(super) created: bool,
}

/// Locks the run directory for this process: a second training (a new run or a `--resume`)
/// on the same directory is refused naming the holder, instead of both writing its files.
/// The lock is the system's (`flock`): a crashed or killed training releases it. A lock
/// taken on a file that was removed meanwhile (by a failed new run, which removes its lock
/// file while holding it) locks nothing, so it is taken again on the file now there.
pub(super) fn lock_run(dir: &Path) -> Result<RunLock, RunError> {
    use std::io::Write as _;
    let path = dir.join(RUN_LOCK);
    loop {
        let (mut file, created) = open_lock_file(&path)?;
        match file.try_lock() {
            Ok(()) => {
                if !same_file(&file, &path) {
                    continue;
                }
                file.set_len(0)
                    .and_then(|()| write!(file, "{}", std::process::id()))
                    .map_err(RunError::io(format!("writing {}", path.display())))?;
                return Ok(RunLock {
                    _file: file,
                    created,
                });
            }
            Err(std::fs::TryLockError::WouldBlock) => {
                let holder = std::fs::read_to_string(&path).unwrap_or_default();
                return Err(RunError::Held {
                    dir: dir.to_path_buf(),
                    pid: holder.trim().to_owned(),
                });
            }
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(RunError::io(format!("locking {}", path.display()))(e));
            }
        }
    }
}

/// Opens (or makes) the lock file at `path`, saying whether this call made it.
fn open_lock_file(path: &Path) -> Result<(std::fs::File, bool), RunError> {
    let open = |create_new: bool| {
        std::fs::OpenOptions::new()
            .create_new(create_new)
            .read(true)
            .write(true)
            .open(path)
    };
    match open(true) {
        Ok(file) => Ok((file, true)),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => match open(false) {
            Ok(file) => Ok((file, false)),
            // Removed between the two opens: make it again.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => open_lock_file(path),
            Err(e) => Err(RunError::io(format!("opening {}", path.display()))(e)),
        },
        Err(e) => Err(RunError::io(format!("opening {}", path.display()))(e)),
    }
}

/// Whether the open `file` is still the file at `path` (not removed or replaced since).
fn same_file(file: &std::fs::File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        match (file.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = file;
        path.exists()
    }
}
