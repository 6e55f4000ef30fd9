//! Studies: seeds × recipes × levels, each trained and then evaluated, planned once into typed
//! steps and a manifest, run by whatever engine the user has (this machine's cores, a Slurm
//! array, Ray tasks), one `study exec STUDY NAME` line per run, and collected from the runs'
//! own files.
//!
//! A study directory holds:
//! - `study.toml`: the spec it was planned from ([`StudySpec`]);
//! - `manifest.json` ([`Manifest`]): every run's name, recipe, level set, seed and its steps as
//!   data — the training ([`RunRecipe`]), the evaluation ([`EvalSpec`]) and optionally a
//!   faithfulness run ([`FaithfulnessSpec`]) — each run with a hash of its steps;
//! - `commands.txt`, `slurm.sbatch`, `ray_driver.py` (`scripts`): the lines an engine runs;
//! - `runs/NAME/`: the run's training directory, with `eval/` and `faithfulness/` reports,
//!   `study.log` (what its steps printed) and [`DONE_FILE`] once every step has ended in order.
//!
//! The steps are parsed from the spec's flags once, by the command line's own parser, when the
//! study is planned: this module deals in typed steps only. A run is an ordinary resumable
//! training, so an engine only schedules: a killed run is run again and goes on from its last
//! checkpoint, under the run directory's own lock.

pub mod collect;
mod error;
mod scripts;
mod spec;
mod steps;

pub use error::StudyError;
pub use scripts::{carried, study_path};
pub use spec::{Cell, LevelSet, PAPER, StudySpec};
pub use steps::{
    Done, EvalSpec, ExecOutcome, Failed, FaithParts, FaithfulnessSpec, RunSteps, Step, Sweep,
};

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::Value;
use sha2::{Digest as _, Sha256};

use crate::run::RunRecipe;

/// `manifest.json`'s `format`.
pub const MANIFEST_FORMAT: &str = "groundscope-study";
/// `manifest.json`'s `version`: 2, the runs' steps as typed data. (A manifest without one was
/// planned when they were command lines: [`Stored::CommandLines`].)
pub const MANIFEST_VERSION: u32 = 2;
/// The file a finished run holds ([`Done`]: its steps all ended in order).
pub const DONE_FILE: &str = "study-done.json";
/// The file a run whose last attempt failed holds ([`Failed`]: the step and its error).
pub const FAILED_FILE: &str = "study-failed.json";
/// What a run's steps printed, appended attempt after attempt.
pub const LOG_FILE: &str = "study.log";
/// The directory of `slurm.sbatch`'s logs in the study, which the plan makes (Slurm fails a
/// task whose `--output` directory does not exist).
pub const SLURM_LOGS: &str = "slurm-logs";

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

/// One run of a study: a recipe on a level set from a seed, and its steps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
    /// The training, into `runs/NAME/`.
    pub train: RunRecipe,
    /// The evaluation of the trained run, into `runs/NAME/eval/`.
    pub eval: EvalSpec,
    /// A faithfulness run after it, into `runs/NAME/faithfulness/`, where the spec asks for it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faithfulness: Option<FaithfulnessSpec>,
    /// Threads its training uses: what an engine reserves for it.
    pub threads: usize,
    /// SHA-256 of the run's name and its steps' canonical JSON: a hand-edited step is refused,
    /// and a plan again may add runs, never change one.
    pub hash: String,
    /// The hash of the steps as `manifest.json` holds them (not as they read back, so that a
    /// field a later version adds with a default leaves a run planned before it intact).
    #[serde(skip)]
    read_hash: Option<String>,
}

/// The steps of a run as they hash.
#[derive(Serialize)]
struct StepsOf<'a> {
    train: &'a RunRecipe,
    eval: &'a EvalSpec,
    #[serde(skip_serializing_if = "Option::is_none")]
    faithfulness: Option<&'a FaithfulnessSpec>,
}

impl PlannedRun {
    /// The run `name`, recipe `recipe` on level set `levels` from `seed`, with its steps,
    /// hashed; its threads are its training's.
    pub fn new(
        name: &str,
        recipe: &str,
        levels: &str,
        seed: u64,
        steps: RunSteps,
    ) -> Result<Self, StudyError> {
        let RunSteps {
            train,
            eval,
            faithfulness,
        } = steps;
        let mut run = Self {
            name: name.to_owned(),
            recipe: recipe.to_owned(),
            levels: levels.to_owned(),
            seed,
            threads: train.ppo.threads.max(1),
            train,
            eval,
            faithfulness,
            hash: String::new(),
            read_hash: None,
        };
        run.hash = run.steps_hash()?;
        Ok(run)
    }

    /// The run's directory inside study `dir`.
    pub fn dir(&self, study: &Path) -> PathBuf {
        study.join("runs").join(&self.name)
    }

    /// Checks a run read from `manifest` (a path, named in the error) before anything of it
    /// runs: its name is a plain name (so its directory is inside `runs/`), and its steps hash
    /// to its recorded `hash` (a hand-edited step is refused, not run unchecked).
    pub fn check(&self, manifest: &Path) -> Result<(), StudyError> {
        let edited = |what: String| {
            Err(StudyError::Edited {
                path: manifest.to_path_buf(),
                what,
            })
        };
        if !is_plain_name(&self.name) {
            return edited(format!(
                "run name {} is not a plain name (letters, digits, '_', '.' and '-', as a plan writes them)",
                shown(&self.name)
            ));
        }
        let actual = match &self.read_hash {
            Some(h) => h.clone(),
            None => self.steps_hash()?,
        };
        if actual != self.hash {
            return edited(format!(
                "run {}: its steps do not hash to its recorded hash",
                self.name
            ));
        }
        Ok(())
    }

    /// Its steps in order.
    pub fn steps(&self) -> Vec<Step> {
        let mut steps = vec![Step::Train, Step::Eval];
        if self.faithfulness.is_some() {
            steps.push(Step::Faithfulness);
        }
        steps
    }

    /// The first of its steps that differs from `other`'s.
    fn changed_step(&self, other: &Self) -> Option<Step> {
        if self.train != other.train {
            Some(Step::Train)
        } else if self.eval != other.eval {
            Some(Step::Eval)
        } else if self.faithfulness != other.faithfulness {
            Some(Step::Faithfulness)
        } else {
            None
        }
    }

    /// The hash of its steps as they are now.
    fn steps_hash(&self) -> Result<String, StudyError> {
        let steps = StepsOf {
            train: &self.train,
            eval: &self.eval,
            faithfulness: self.faithfulness.as_ref(),
        };
        // Through the text, as the manifest holds it: a value's JSON (an f32's shortest
        // digits) reads back as what it was written from.
        let canonical = serde_json::to_string(&steps)
            .and_then(|text| serde_json::from_str::<Value>(&text))
            .map_err(|e| StudyError::Json {
                run: self.name.clone(),
                error: e.to_string(),
            })?;
        Ok(hash_steps(&self.name, &canonical))
    }
}

/// The hash of run `name` whose steps are `steps` (a JSON object of `train`, `eval` and
/// `faithfulness`): SHA-256 of the name and the steps' compact JSON, whose objects' keys are
/// in one order whatever order a file had them in.
fn hash_steps(name: &str, steps: &Value) -> String {
    let mut h = Sha256::new();
    h.update(name.as_bytes());
    h.update([0]);
    h.update(steps.to_string().as_bytes());
    format!("{:x}", h.finalize())
}

/// The hash of the steps of `run`, a run of `manifest.json` as it reads as JSON.
fn stored_hash(name: &str, run: &Value) -> String {
    let mut steps = serde_json::Map::new();
    for key in ["train", "eval", "faithfulness"] {
        if let Some(v) = run.get(key) {
            steps.insert(key.to_owned(), v.clone());
        }
    }
    hash_steps(name, &Value::Object(steps))
}

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`MANIFEST_FORMAT`].
    pub format: String,
    /// [`MANIFEST_VERSION`].
    pub version: u32,
    /// The study's name (its directory's).
    pub name: String,
    /// The binary that runs the lines (`commands.txt`, the sbatch script, the Ray driver).
    pub binary: String,
    /// Every run, in the order the engines take them: seed by seed, recipe by recipe.
    pub runs: Vec<PlannedRun>,
}

/// A `manifest.json` as it was read: typed, or planned when the runs' steps were command lines.
#[derive(Clone, Debug)]
pub enum Stored {
    /// This version's manifest.
    Typed(Manifest),
    /// An earlier one, whose steps are command lines: its text, for the command line's parser
    /// to turn into typed steps.
    CommandLines {
        /// The file.
        path: PathBuf,
        /// Its text.
        text: String,
    },
}

impl Manifest {
    /// The manifest of study `name` with `runs`, run by `binary`.
    pub fn new(name: &str, binary: &str, runs: Vec<PlannedRun>) -> Self {
        Self {
            format: MANIFEST_FORMAT.into(),
            version: MANIFEST_VERSION,
            name: name.to_owned(),
            binary: binary.to_owned(),
            runs,
        }
    }

    /// Reads `STUDY/manifest.json`, naming the file in every error; one planned when the steps
    /// were command lines is refused as [`StudyError::CommandLines`] ([`Self::read_stored`]
    /// hands it over instead).
    pub fn read(study: &Path) -> Result<Self, StudyError> {
        match Self::read_stored(study)? {
            Stored::Typed(m) => Ok(m),
            Stored::CommandLines { path, .. } => Err(StudyError::CommandLines { path }),
        }
    }

    /// Reads `STUDY/manifest.json`, typed or as an earlier version left it.
    pub fn read_stored(study: &Path) -> Result<Stored, StudyError> {
        let path = study.join("manifest.json");
        let text = crate::files::read_regular_to_string(&path).map_err(|error| {
            StudyError::NoManifest {
                path: path.clone(),
                study: study.to_path_buf(),
                error,
            }
        })?;
        let bad = |what: String| StudyError::BadManifest {
            path: path.clone(),
            what,
        };
        let value: Value =
            serde_json::from_str(&text).map_err(|e| bad(one_line(&e.to_string())))?;
        let format = value.get("format").and_then(Value::as_str);
        if format != Some(MANIFEST_FORMAT) {
            let what = format.map_or_else(
                || "no format".to_owned(),
                |f| format!("format {}", shown(f)),
            );
            return Err(bad(format!("{what} is not {MANIFEST_FORMAT:?}")));
        }
        match value.get("version") {
            None => {
                return Ok(Stored::CommandLines {
                    path: path.clone(),
                    text,
                });
            }
            Some(v) if v.as_u64() == Some(u64::from(MANIFEST_VERSION)) => {}
            Some(v) => {
                return Err(bad(format!(
                    "version {}: this groundscope reads version {MANIFEST_VERSION}; plan the study again with it (groundscope study plan SPEC --out {})",
                    shown(&v.to_string()),
                    study.display()
                )));
            }
        }
        let mut m: Self = serde_json::from_str(&text).map_err(|e| bad(one_line(&e.to_string())))?;
        if let Some(runs) = value.get("runs").and_then(Value::as_array) {
            for (run, raw) in m.runs.iter_mut().zip(runs) {
                run.read_hash = Some(stored_hash(&run.name, raw));
            }
        }
        Ok(Stored::Typed(m))
    }

    /// The manifest as `manifest.json` holds it.
    pub fn to_json(&self) -> Result<String, StudyError> {
        serde_json::to_string_pretty(self)
            .map(|text| text + "\n")
            .map_err(|e| StudyError::Json {
                run: self.name.clone(),
                error: e.to_string(),
            })
    }

    /// Checks every run ([`PlannedRun::check`]) and that no two share a name (a directory),
    /// for a runner that is about to run them: `manifest` names the file in the error.
    pub fn check_runs(&self, manifest: &Path) -> Result<(), StudyError> {
        let mut seen = std::collections::BTreeSet::new();
        for run in &self.runs {
            run.check(manifest)?;
            if !seen.insert(run.name.as_str()) {
                return Err(StudyError::Edited {
                    path: manifest.to_path_buf(),
                    what: format!("run {} is listed twice", run.name),
                });
            }
        }
        Ok(())
    }

    /// The run called `name`.
    pub fn run(&self, name: &str) -> Result<&PlannedRun, StudyError> {
        self.runs
            .iter()
            .find(|r| r.name == name)
            .ok_or_else(|| StudyError::NoRun {
                study: shown(&self.name),
                name: shown(name),
                runs: self
                    .runs
                    .iter()
                    .map(|r| shown(&r.name))
                    .take(6)
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }
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
/// is refused by name (its directory holds results of the old steps). The steps are compared
/// as data, so a manifest planned by an earlier version compares by what its steps mean.
pub fn check_replan(old: &Manifest, new: &Manifest) -> Result<(), StudyError> {
    for run in &old.runs {
        let Some(r) = new.runs.iter().find(|r| r.name == run.name) else {
            return Err(StudyError::Dropped(run.name.clone()));
        };
        if let Some(step) = run.changed_step(r) {
            return Err(StudyError::Changed {
                run: run.name.clone(),
                step,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
