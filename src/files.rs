//! Small file-system helpers shared by every writer: the one place where outputs are made
//! durable and atomic.
//!
//! A regular file (or a path that does not exist yet) is replaced atomically: the bytes go to a
//! temporary file beside it, are flushed to disk, and the temporary file is renamed over the
//! destination, whose directory is then flushed too; a crash at any instant leaves the old file
//! or the new one, complete. A symlink is followed and its target replaced, so the link stays a
//! link. Anything else (a character device, a FIFO) is written in place and never replaced.

use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Reads a whole file that must be a regular file: a FIFO, socket, device or directory is
/// refused (`InvalidInput`, naming what it is) before it is opened, since opening a FIFO for
/// reading waits for a writer forever.
pub fn read_regular(path: &Path) -> std::io::Result<Vec<u8>> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("not a regular file ({})", file_kind(&meta)),
        ));
    }
    std::fs::read(path)
}

/// [`read_regular`] as UTF-8 text.
pub fn read_regular_to_string(path: &Path) -> std::io::Result<String> {
    String::from_utf8(read_regular(path)?)
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// What a non-regular file is, in words.
fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
    }
    "not a plain file"
}

/// The most text [`read_text_maybe_gz`] reads (64 MiB, 200 times the longest BabyAI dump):
/// a few MB of gzip can expand a thousandfold, and a dump's text is held in memory several
/// times over while it is parsed.
pub const TEXT_BYTES_MAX: u64 = 64 << 20;

/// Reads a text file, gunzipping it when its name ends in `.gz` (the compressed minigrid
/// dumps). Invalid UTF-8 or a broken gzip stream is an `InvalidData` error; so is text over
/// [`TEXT_BYTES_MAX`], refused before it is all read (a plain file by its size, a gzip as it
/// expands).
pub fn read_text_maybe_gz(path: &Path) -> std::io::Result<String> {
    use std::io::Read as _;
    let too_long = |what: &str| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "{what} more than {} MiB, the most a dump may hold (docs/formats.md#snapshots)",
                TEXT_BYTES_MAX >> 20
            ),
        )
    };
    let meta = std::fs::metadata(path)?;
    if meta.is_file() && meta.len() > TEXT_BYTES_MAX {
        return Err(too_long("holds"));
    }
    let bytes = read_regular(path)?;
    let text = if path.extension().is_some_and(|e| e == "gz") {
        let mut text = Vec::new();
        flate2::read::GzDecoder::new(bytes.as_slice())
            .take(TEXT_BYTES_MAX + 1)
            .read_to_end(&mut text)?;
        if text.len() as u64 > TEXT_BYTES_MAX {
            return Err(too_long("expands to"));
        }
        text
    } else {
        bytes
    };
    String::from_utf8(text).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// Gives a finished temporary file (which `tempfile` creates with mode 0600) the mode of a
/// normally created file, 0644, before it is renamed into place.
pub fn make_shareable(path: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o644))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        Ok(())
    }
}

/// How an output path is to be written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OutputKind {
    /// A regular file or a new path: write a temporary file beside this path and rename it.
    Replace(PathBuf),
    /// A device, FIFO or other special file: write into it directly.
    InPlace(PathBuf),
}

/// Decides how `path` is written (symlinks resolved to their final target).
pub fn output_kind(path: &Path) -> std::io::Result<OutputKind> {
    match std::fs::metadata(path) {
        Ok(meta) if meta.is_file() => Ok(OutputKind::Replace(resolve(path)?)),
        Ok(meta) if meta.is_dir() => Err(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            "is a directory",
        )),
        Ok(_) => Ok(OutputKind::InPlace(path.to_path_buf())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // A dangling symlink: create its target rather than replacing the link.
            match std::fs::read_link(path) {
                Ok(target) => {
                    let base = path.parent().unwrap_or(Path::new("."));
                    Ok(OutputKind::Replace(base.join(target)))
                }
                Err(_) => Ok(OutputKind::Replace(path.to_path_buf())),
            }
        }
        Err(e) => Err(e),
    }
}

fn resolve(path: &Path) -> std::io::Result<PathBuf> {
    if std::fs::symlink_metadata(path)?.file_type().is_symlink() {
        std::fs::canonicalize(path)
    } else {
        Ok(path.to_path_buf())
    }
}

/// The file an output path names, for telling two outputs of one command apart before either
/// is written: a path that exists by its canonical form (symlinks followed), a new one by its
/// directory's canonical form and its name (a dangling symlink by its target's). A path whose
/// directory does not exist is returned as given: writing it fails anyway.
pub fn output_identity(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    let path = match std::fs::read_link(path) {
        Ok(target) => parent_dir(path).join(target),
        Err(_) => path.to_path_buf(),
    };
    match (std::fs::canonicalize(parent_dir(&path)), path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path,
    }
}

/// An output as a command names it: its flag and its path.
pub type NamedOutput<'a> = (&'a str, &'a Path);

/// The first two of `outputs` that name the same file ([`output_identity`]). `/dev/null` may
/// take any number.
pub fn same_output<'a>(outputs: &[NamedOutput<'a>]) -> Option<(NamedOutput<'a>, NamedOutput<'a>)> {
    let ids: Vec<PathBuf> = outputs.iter().map(|(_, p)| output_identity(p)).collect();
    for (i, a) in ids.iter().enumerate() {
        if a == Path::new("/dev/null") {
            continue;
        }
        if let Some(j) = ids.iter().skip(i + 1).position(|b| b == a) {
            return Some((*outputs.get(i)?, *outputs.get(i + 1 + j)?));
        }
    }
    None
}

/// The directory a path lives in (`.` for a bare file name).
pub fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Flushes a directory's entries (a rename in it) to disk.
pub fn sync_dir(dir: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        std::fs::File::open(dir)?.sync_all()
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        Ok(())
    }
}

/// A hidden temporary file in `dir` (`.groundscope-*.tmp`) for an output being written. Its
/// creation error is the system's reason alone: `tempfile` adds the temporary's own name,
/// which the user never gave (the caller names the output's path).
pub fn temp_file_in(dir: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    temp_file_named(dir, ".tmp")
}

/// [`temp_file_in`] with this suffix (a recording's `.rrd.partial`, say, so that a file left
/// by a killed process says what it was).
pub fn temp_file_named(dir: &Path, suffix: &str) -> std::io::Result<tempfile::NamedTempFile> {
    tempfile::Builder::new()
        .prefix(".groundscope-")
        .suffix(suffix)
        .tempfile_in(dir)
        .map_err(|e| {
            // tempfile's error reads "<system's reason> at path \"<temporary>\"" and keeps no
            // other handle on the reason, so the suffix is cut from the text.
            let text = e.to_string();
            match text.rfind(" at path ") {
                Some(i) => std::io::Error::new(e.kind(), text[..i].to_owned()),
                None => e,
            }
        })
}

/// Writes `bytes` to `path` as the module doc says: atomically and durably for regular files,
/// in place for special files. On error nothing new is left beside `path`.
pub fn write_output(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    match output_kind(path)? {
        OutputKind::InPlace(p) => {
            let mut f = std::fs::OpenOptions::new().write(true).open(&p)?;
            f.write_all(bytes)?;
            f.flush()
        }
        OutputKind::Replace(p) => {
            let dir = parent_dir(&p);
            staged(dir, bytes)?.persist(&p).map_err(|e| e.error)?;
            sync_dir(dir)
        }
    }
}

/// `bytes` in a temporary file of `dir`, on disk and readable as the final file will be: what
/// [`write_output`] renames into place, and what a writer of several files that must change
/// together (a checkpoint's pair) renames itself.
pub fn staged(dir: &Path, bytes: &[u8]) -> std::io::Result<tempfile::TempPath> {
    let mut tmp = temp_file_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    make_shareable(tmp.path())?;
    Ok(tmp.into_temp_path())
}

/// Renames a finished temporary file onto `dest` durably (data flushed first, then the
/// directory), the way [`write_output`] does for bytes already in memory.
pub fn commit_temp(tmp: tempfile::TempPath, dest: &Path) -> std::io::Result<()> {
    std::fs::File::open(&tmp)?.sync_all()?;
    make_shareable(&tmp)?;
    tmp.persist(dest).map_err(|e| e.error)?;
    sync_dir(parent_dir(dest))
}

/// An I/O error and the path it concerns (the path the user gave, never a temporary's).
#[derive(Debug, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct PathError {
    /// The file or directory.
    pub path: PathBuf,
    /// What went wrong.
    pub reason: String,
}

impl PathError {
    fn new(path: &Path, reason: impl std::fmt::Display) -> Self {
        Self {
            path: path.to_path_buf(),
            reason: reason.to_string(),
        }
    }
}

/// A directory of outputs that change together (an evaluation report, a faithfulness report):
/// every file is written into a hidden directory inside it and moved into place only when all
/// are complete ([`Self::commit`]). Dropped before that — the run failed — it removes the
/// hidden directory, and the output directory too when this run created it and it is empty,
/// so a failed run leaves nothing behind.
#[derive(Debug)]
pub struct StagedDir {
    staging: Option<tempfile::TempDir>,
    out: PathBuf,
    created: bool,
}

impl StagedDir {
    /// Creates `out` if needed and a hidden staging directory inside it.
    pub fn new(out: &Path) -> Result<Self, PathError> {
        if out.exists() && !out.is_dir() {
            return Err(PathError::new(out, "not a directory"));
        }
        let created = !out.exists();
        std::fs::create_dir_all(out).map_err(|e| PathError::new(out, e))?;
        let staging = tempfile::Builder::new()
            .prefix(".groundscope-staging-")
            .tempdir_in(out)
            .map_err(|e| PathError::new(out, e));
        let staging = match staging {
            Ok(s) => s,
            Err(e) => {
                if created {
                    let _ = std::fs::remove_dir(out);
                }
                return Err(e);
            }
        };
        Ok(Self {
            staging: Some(staging),
            out: out.to_path_buf(),
            created,
        })
    }

    /// Where the file `name` is written now (inside the staging directory).
    pub fn path(&self, name: &str) -> PathBuf {
        self.staging
            .as_ref()
            .map_or_else(|| self.out.join(name), |d| d.path().join(name))
    }

    /// The staging directory itself, for writers that name their own files in it.
    pub fn dir(&self) -> &Path {
        self.staging
            .as_ref()
            .map_or(&self.out, tempfile::TempDir::path)
    }

    /// The file `name` will end up here.
    pub fn final_path(&self, name: &str) -> PathBuf {
        self.out.join(name)
    }

    /// Writes the file `name`; an error names its final path.
    pub fn write(&self, name: &str, bytes: &[u8]) -> Result<(), PathError> {
        std::fs::write(self.path(name), bytes)
            .map_err(|e| PathError::new(&self.final_path(name), e))
    }

    /// Moves every staged file into the output directory (replacing older ones), flushes the
    /// directory and returns how many files moved.
    pub fn commit(self) -> Result<usize, PathError> {
        self.commit_owned(|_| false)
    }

    /// [`Self::commit`], then removes the files of the output directory that `owns` (the names
    /// the command writes) and this run did not write: a reused directory ends up holding this
    /// run's outputs, not an earlier run's leftovers beside them. Other files are left alone.
    pub fn commit_owned(mut self, owns: impl Fn(&str) -> bool) -> Result<usize, PathError> {
        let Some(staging) = self.staging.take() else {
            return Ok(0);
        };
        let mut moved = std::collections::HashSet::new();
        let entries =
            std::fs::read_dir(staging.path()).map_err(|e| PathError::new(&self.out, e))?;
        for entry in entries {
            let entry = entry.map_err(|e| PathError::new(&self.out, e))?;
            let dest = self.out.join(entry.file_name());
            std::fs::rename(entry.path(), &dest).map_err(|e| PathError::new(&dest, e))?;
            moved.insert(entry.file_name());
        }
        let entries = std::fs::read_dir(&self.out).map_err(|e| PathError::new(&self.out, e))?;
        for entry in entries.flatten() {
            let name = entry.file_name();
            let stale = !moved.contains(&name)
                && entry.file_type().is_ok_and(|t| t.is_file())
                && name.to_str().is_some_and(&owns);
            if stale {
                std::fs::remove_file(entry.path()).map_err(|e| PathError::new(&entry.path(), e))?;
            }
        }
        sync_dir(&self.out).map_err(|e| PathError::new(&self.out, e))?;
        Ok(moved.len())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if let Some(staging) = self.staging.take() {
            drop(staging);
            if self.created {
                // `remove_dir` removes only an empty directory.
                let _ = std::fs::remove_dir(&self.out);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_staged_directory_appears_whole_or_not_at_all() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("report");
        // Dropped before commit: nothing is left, not even the directory it created.
        {
            let staged = StagedDir::new(&out).unwrap();
            staged.write("a.json", b"1").unwrap();
            assert!(!out.join("a.json").exists());
        }
        assert!(!out.exists());
        // Committed: every file, and no staging directory beside them.
        let staged = StagedDir::new(&out).unwrap();
        staged.write("a.json", b"1").unwrap();
        staged.write("b.csv", b"2").unwrap();
        assert_eq!(staged.commit().unwrap(), 2);
        let mut names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["a.json", "b.csv"]);
        // A directory it did not create stays when a later run fails.
        drop(StagedDir::new(&out).unwrap());
        assert!(out.join("a.json").exists());
        let file = out.join("a.json");
        assert!(
            StagedDir::new(&file)
                .unwrap_err()
                .to_string()
                .contains("not a directory")
        );
    }

    #[test]
    fn a_missing_directory_is_reported_without_the_temporary_name() {
        let dir = tempfile::tempdir().unwrap();
        let e = write_output(&dir.path().join("nodir/t.json"), b"{}")
            .unwrap_err()
            .to_string();
        assert!(!e.contains(".groundscope-"), "{e}");
        assert!(e.contains("No such file or directory"), "{e}");
    }

    #[test]
    fn regular_files_are_replaced_and_symlinks_kept() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("real.txt");
        std::fs::write(&target, b"old").unwrap();
        let link = dir.path().join("link.txt");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_output(&link, b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 2, "no temporary file is left");
    }

    #[test]
    fn special_files_are_written_in_place_and_report_their_errors() {
        // /dev/full is a character device whose writes fail with ENOSPC.
        let err = write_output(Path::new("/dev/full"), b"x").unwrap_err();
        assert_eq!(err.raw_os_error(), Some(28));
        write_output(Path::new("/dev/null"), b"x").unwrap();
        assert!(
            std::fs::metadata("/dev/null")
                .unwrap()
                .file_type()
                .is_char_device()
        );
    }

    #[test]
    fn two_spellings_of_one_output_are_the_same_file() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("d.rrd");
        let b = dir.path().join(".").join("d.rrd");
        let c = dir.path().join("e.rrd");
        assert!(same_output(&[("--save", a.as_path()), ("--trace", c.as_path())]).is_none());
        let (x, y) = same_output(&[
            ("--save", a.as_path()),
            ("--mcap", c.as_path()),
            ("--trace", b.as_path()),
        ])
        .unwrap();
        assert_eq!((x.0, y.0), ("--save", "--trace"));
        // A link and the file it names, whether or not the file exists yet.
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink(&c, &link).unwrap();
        assert!(same_output(&[("--save", c.as_path()), ("--trace", link.as_path())]).is_some());
        std::fs::write(&c, b"x").unwrap();
        assert!(same_output(&[("--save", c.as_path()), ("--trace", link.as_path())]).is_some());
        let null = Path::new("/dev/null");
        assert!(same_output(&[("--save", null), ("--trace", null)]).is_none());
    }

    use std::os::unix::fs::FileTypeExt as _;
}
