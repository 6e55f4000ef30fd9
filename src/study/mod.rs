//! Studies: seeds × recipes × levels, each trained and then evaluated, planned once into plain
//! command lines and a manifest, run by whatever engine the user has (this machine's cores, a
//! Slurm array, Ray tasks) and collected from the runs' own files.
//!
//! A study directory holds:
//! - `study.toml`: the spec it was planned from;
//! - `manifest.json`: every run's name, recipe, level set, seed and the arguments of its steps
//!   (`train`, then `eval`, then optionally `faithfulness`), each with a hash of its spec;
//! - `commands.txt`: one `groundscope study exec STUDY NAME` line per run, in manifest order;
//! - `slurm.sbatch`: an array job that runs line `$SLURM_ARRAY_TASK_ID`, logging into
//!   `slurm-logs/` (which the plan makes);
//! - `ray_driver.py`: the same lines as Ray tasks;
//! - `runs/NAME/`: the run's training directory, with `eval/` and `faithfulness/` reports,
//!   `study.log` (what its steps printed) and `study-done.json` once every step has ended.
//!
//! Each step is an ordinary resumable command, so an engine only schedules: a killed run is
//! run again with `train --resume` and goes on from its last checkpoint.

pub mod collect;
mod spec;

pub use spec::{LevelSet, StudySpec};

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest as _, Sha256};

/// `manifest.json`'s `format`.
pub const MANIFEST_FORMAT: &str = "groundscope-study";
/// The file a finished run holds (its steps all ended with status 0).
pub const DONE_FILE: &str = "study-done.json";
/// The file a run whose last attempt failed holds: the step and its exit status.
pub const FAILED_FILE: &str = "study-failed.json";
/// The lock a run's executor holds while it runs (so one run never runs twice at once).
pub const LOCK_FILE: &str = ".study-lock";
/// What a run's steps printed, appended attempt after attempt.
pub const LOG_FILE: &str = "study.log";
/// The directory of `slurm.sbatch`'s logs in the study, which the plan makes (Slurm fails a
/// task whose `--output` directory does not exist).
pub const SLURM_LOGS: &str = "slurm-logs";

/// An error in a study's spec or files, naming the file and the field.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct StudyError(pub String);

/// Text from a spec or a manifest (a recipe's name, a flag, a value) as a study's error quotes
/// it: quoted, control characters escaped, cut after 80 characters.
pub fn shown(text: &str) -> String {
    crate::env::error::shown(text)
}

/// The most bytes of another library's message that a study's error quotes.
const MESSAGE_MAX: usize = 300;

/// Another library's message (TOML's, clap's, serde's), which may quote the user's text, as
/// part of a study's one-line error: its whitespace joined into single spaces, control
/// characters escaped, cut after [`MESSAGE_MAX`] bytes (saying how long it was).
pub fn one_line(text: &str) -> String {
    let joined = text.split_whitespace().collect::<Vec<_>>().join(" ");
    let mut out = String::new();
    for c in joined.chars() {
        if out.len() >= MESSAGE_MAX {
            let _ = write!(out, "… ({} characters)", joined.chars().count());
            return out;
        }
        if c.is_control() {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    out
}

/// Whether `name` is a plain run name, as a plan makes them: letters, digits, `_`, `.` and
/// `-`, one path component (not `.` or `..`), short enough to name a directory.
pub fn is_plain_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 255
        && name != "."
        && name != ".."
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.' || c == '-')
}

/// One run of a study: a recipe on a level set from a seed.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlannedRun {
    /// `RECIPE-LEVELS-sSEED`: the run's directory under `runs/`.
    pub name: String,
    /// The recipe's name.
    pub recipe: String,
    /// The level set's name.
    pub levels: String,
    /// The training seed.
    pub seed: u64,
    /// `groundscope train` arguments (without the program), run in the study directory.
    pub train: Vec<String>,
    /// `groundscope eval` arguments.
    pub eval: Vec<String>,
    /// `groundscope faithfulness` arguments, where the spec asks for it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faithfulness: Option<Vec<String>>,
    /// Threads its training uses (`--threads`): what an engine reserves for it.
    pub threads: usize,
    /// SHA-256 of the run's name and steps: a plan again may add runs, never change one.
    pub hash: String,
}

impl PlannedRun {
    /// The run's directory inside study `dir`.
    pub fn dir(&self, study: &Path) -> PathBuf {
        study.join("runs").join(&self.name)
    }

    /// Checks a run read from `manifest` (a path, named in the error) before anything of it
    /// runs: its name is a plain name (so its directory is inside `runs/`), and its steps hash
    /// to its recorded `hash` (a hand-edited step is refused, not run unchecked).
    pub fn check(&self, manifest: &Path) -> Result<(), StudyError> {
        if !is_plain_name(&self.name) {
            return Err(StudyError(format!(
                "{}: run name {} is not a plain name (letters, digits, '_', '.' and '-', as a plan writes them): the manifest was edited; plan the study again (groundscope study plan SPEC --out STUDY)",
                manifest.display(),
                shown(&self.name)
            )));
        }
        if run_hash(&self.name, &self.steps()) != self.hash {
            return Err(StudyError(format!(
                "{}: run {}: its steps do not hash to its recorded hash (the manifest was edited); plan the study again (groundscope study plan SPEC --out STUDY)",
                manifest.display(),
                self.name
            )));
        }
        Ok(())
    }

    /// Its steps in order: `(command, arguments)`.
    pub fn steps(&self) -> Vec<(&'static str, &[String])> {
        let mut steps = vec![
            ("train", self.train.as_slice()),
            ("eval", self.eval.as_slice()),
        ];
        if let Some(f) = &self.faithfulness {
            steps.push(("faithfulness", f.as_slice()));
        }
        steps
    }
}

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`MANIFEST_FORMAT`].
    pub format: String,
    /// The study's name (its directory's).
    pub name: String,
    /// The binary that runs the lines (`commands.txt`, the sbatch script, the Ray driver).
    pub binary: String,
    /// Every run, in the order the engines take them: seed by seed, recipe by recipe.
    pub runs: Vec<PlannedRun>,
}

impl Manifest {
    /// Reads `STUDY/manifest.json`, naming the file in every error.
    pub fn read(study: &Path) -> Result<Self, StudyError> {
        let path = study.join("manifest.json");
        let text = crate::files::read_regular_to_string(&path).map_err(|e| {
            StudyError(format!(
                "{}: {e} (plan the study first: groundscope study plan SPEC --out {})",
                path.display(),
                study.display()
            ))
        })?;
        let m: Self = serde_json::from_str(&text)
            .map_err(|e| StudyError(format!("{}: {}", path.display(), one_line(&e.to_string()))))?;
        if m.format != MANIFEST_FORMAT {
            return Err(StudyError(format!(
                "{}: format {} is not {MANIFEST_FORMAT:?}",
                path.display(),
                shown(&m.format)
            )));
        }
        Ok(m)
    }

    /// Checks every run ([`PlannedRun::check`]) and that no two share a name (a directory),
    /// for a runner that is about to run them: `manifest` names the file in the error.
    pub fn check_runs(&self, manifest: &Path) -> Result<(), StudyError> {
        let mut seen = std::collections::BTreeSet::new();
        for run in &self.runs {
            run.check(manifest)?;
            if !seen.insert(run.name.as_str()) {
                return Err(StudyError(format!(
                    "{}: run {} is listed twice: the manifest was edited; plan the study again (groundscope study plan SPEC --out STUDY)",
                    manifest.display(),
                    run.name
                )));
            }
        }
        Ok(())
    }

    /// The run called `name`.
    pub fn run(&self, name: &str) -> Result<&PlannedRun, StudyError> {
        self.runs.iter().find(|r| r.name == name).ok_or_else(|| {
            StudyError(format!(
                "the study {} has no run {} (its runs: {})",
                shown(&self.name),
                shown(name),
                self.runs
                    .iter()
                    .map(|r| shown(&r.name))
                    .take(6)
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })
    }

    /// `commands.txt`: one line per run, each word quoted as sh reads it (`sh_word`), so
    /// that a binary or a study whose path holds a space or a quote runs as planned.
    pub fn commands(&self, study: &Path) -> String {
        let binary = sh_word(&self.binary);
        let dir = shell(study);
        let mut out = String::new();
        for r in &self.runs {
            let _ = writeln!(out, "{binary} study exec {dir} {}", sh_word(&r.name));
        }
        out
    }

    /// `slurm.sbatch`: an array of one task per line of `commands.txt`, each with the CPUs its
    /// training uses; logs in `slurm-logs/`. Paths in the script's body are quoted as sh reads
    /// them; those of the `#SBATCH` lines, which sbatch reads itself, as sbatch does
    /// (`sbatch_value`).
    pub fn sbatch(&self, study: &Path) -> String {
        let cpus = self.runs.iter().map(|r| r.threads).max().unwrap_or(1);
        let last = self.runs.len().saturating_sub(1);
        let name = &self.name;
        // A job's name is only shown: letters, digits and `_.-` of the study's, the rest `_`.
        let job: String = name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "_.-".contains(c) {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        // `%` starts one of Slurm's file name patterns (`%A`, `%a`): a literal one is `%%`.
        let logs = format!(
            "{}/{SLURM_LOGS}/%A_%a.txt",
            study.display().to_string().replace('%', "%%")
        );
        let output = sbatch_value(&logs);
        let script = shell(&study.join("slurm.sbatch"));
        let commands = shell(&study.join("commands.txt"));
        let dir = shell(study);
        format!(
            "#!/bin/bash\n\
             # groundscope study {name}: one array task per line of commands.txt.\n\
             # Submit: sbatch {script}   (then: groundscope study collect {dir})\n\
             #SBATCH --job-name=gs-{job}\n\
             #SBATCH --array=0-{last}\n\
             #SBATCH --cpus-per-task={cpus}\n\
             #SBATCH --output={output}\n\
             set -euo pipefail\n\
             line=$(sed -n \"$((SLURM_ARRAY_TASK_ID + 1))p\" {commands})\n\
             exec bash -c \"$line\"\n"
        )
    }

    /// `ray_driver.py`: every run as a Ray task with `num_cpus` = its threads, on the cluster
    /// at `--address` (default: a local one); waits for all and names the ones that failed.
    pub fn ray_driver(study: &Path) -> String {
        // A JSON string is a Python string literal, whatever the path holds.
        let literal = serde_json::to_string(&study.display().to_string()).unwrap_or_default();
        include_str!("ray_driver.py").replace("\"@STUDY@\"", &literal)
    }
}

/// A path that the plan writes into its files (`commands.txt`, `slurm.sbatch`,
/// `ray_driver.py`, `manifest.json`), as text; `what` names it in the error. Refused where
/// those files cannot carry it: a path that is not UTF-8 (the manifest is JSON text), or that
/// holds a control character — a newline would end a line of `commands.txt` (a task would run
/// half a path) and, in `slurm.sbatch`, run the rest of the path as a command.
pub fn carried<'a>(path: &'a Path, what: &str) -> Result<&'a str, StudyError> {
    let Some(text) = path.to_str() else {
        return Err(StudyError(format!(
            "{what} {}: not valid UTF-8, which manifest.json and the study's scripts cannot carry; choose another path",
            shown(&path.to_string_lossy())
        )));
    };
    if let Some(c) = text.chars().find(|&c| c.is_control()) {
        return Err(StudyError(format!(
            "{what} {}: holds a control character ('{}'), which commands.txt and slurm.sbatch cannot carry (a newline would end a command line, or run the rest of the path as a command); choose a path without one",
            shown(text),
            c.escape_debug()
        )));
    }
    Ok(text)
}

/// The study directory's path as the plan writes it ([`carried`]), also refused where it
/// holds a backslash: Slurm reads a `\` in `--output` as "no file name patterns", so every
/// task of `slurm.sbatch` would log into one file named `%A_%a.txt`.
pub fn study_path(study: &Path) -> Result<&str, StudyError> {
    let text = carried(study, "--out")?;
    if text.contains('\\') {
        return Err(StudyError(format!(
            "--out {}: holds a backslash, which slurm.sbatch cannot carry (Slurm reads one in --output as \"no file name patterns\": every task would log into one file); choose a path without one",
            shown(text)
        )));
    }
    Ok(text)
}

/// Whether `s` needs no quoting: letters, digits and `/._-+,=:` (`%` too for sbatch).
fn plain_word(s: &str, extra: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+,=:".contains(c) || extra.contains(c))
}

/// `s` as one sh word: as it is where it holds only safe characters, else in single quotes,
/// each `'` written `'\''` (sh takes everything between single quotes literally).
fn sh_word(s: &str) -> String {
    if plain_word(s, "") {
        s.to_owned()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// A path as one sh word ([`sh_word`]).
fn shell(p: &Path) -> String {
    sh_word(&p.display().to_string())
}

/// A value of a `#SBATCH` option as sbatch's own parser of those lines reads it back: as it
/// is where it holds only safe characters, else in double quotes (sbatch ends a value at a
/// space outside quotes) with `\`, `"`, `'` and `#` escaped by a backslash (sbatch undoes a
/// backslash before any character, ends a quote at its own quote character, and takes a `#`
/// as the start of a comment — outside quotes, and in older versions inside them too).
fn sbatch_value(s: &str) -> String {
    if plain_word(s, "%") {
        return s.to_owned();
    }
    let mut out = String::from("\"");
    for c in s.chars() {
        if matches!(c, '\\' | '"' | '\'' | '#') {
            out.push('\\');
        }
        out.push(c);
    }
    out.push('"');
    out
}

/// The hash of a run: its name and every step's arguments.
fn run_hash(name: &str, steps: &[(&str, &[String])]) -> String {
    let mut h = Sha256::new();
    h.update(name.as_bytes());
    for (cmd, args) in steps {
        h.update([0]);
        h.update(cmd.as_bytes());
        for a in *args {
            h.update([1]);
            h.update(a.as_bytes());
        }
    }
    format!("{:x}", h.finalize())
}

/// Where each run of a study stands, from its own files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RunState {
    /// Not started.
    Pending,
    /// Started (a training directory or a log) and not finished: resumable.
    Partial,
    /// Its last attempt failed (`study-failed.json`).
    Failed,
    /// Every step ended with status 0 (`study-done.json`).
    Done,
}

impl RunState {
    /// The state of `run` in study `dir` (the lock is not looked at: a running run is partial).
    pub fn of(study: &Path, run: &PlannedRun) -> Self {
        let dir = run.dir(study);
        if dir.join(DONE_FILE).is_file() {
            Self::Done
        } else if dir.join(FAILED_FILE).is_file() {
            Self::Failed
        } else if dir.exists() {
            Self::Partial
        } else {
            Self::Pending
        }
    }

    /// Lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pending => "pending",
            Self::Partial => "unfinished",
            Self::Failed => "failed",
            Self::Done => "done",
        }
    }
}

/// Checks a new plan against the manifest already in the study: the same runs give the same
/// manifest; new runs may be added; a run whose steps changed, or that the spec no longer has,
/// is refused by name (its directory holds results of the old steps).
pub fn check_replan(old: &Manifest, new: &Manifest) -> Result<(), StudyError> {
    for run in &old.runs {
        match new.runs.iter().find(|r| r.name == run.name) {
            None => {
                return Err(StudyError(format!(
                    "the new spec drops run {} of the planned study; a study's runs may only be added (plan into a new --out)",
                    run.name
                )));
            }
            Some(r) if r.hash != run.hash => {
                return Err(StudyError(format!(
                    "the new spec changes run {} (its {} arguments differ from the planned ones); a study's runs may only be added (plan into a new --out)",
                    run.name,
                    changed_step(run, r)
                )));
            }
            Some(_) => {}
        }
    }
    Ok(())
}

fn changed_step(old: &PlannedRun, new: &PlannedRun) -> &'static str {
    if old.train != new.train {
        "train"
    } else if old.eval != new.eval {
        "eval"
    } else {
        "faithfulness"
    }
}
