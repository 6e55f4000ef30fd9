//! An evaluation read back (`view --report DIR`): its episodes (`episodes.csv`, read by
//! [`super::read_episodes_csv`]), the action mode they ran in and the Python policies among its
//! checkpoints (`report.json`), and what reopens each episode — checkpoint, level in its done
//! mode, seed, sampling and the step to open at — or, for a Python policy's, what replays it
//! read-only from the actions the report recorded ([`RecordedEpisode`]). No UI here, and no
//! choice of what to list: the debugger's episodes panel filters and sorts what this reads.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use super::episodes::{EpisodeRow, read_episodes_csv};
use crate::env::level::LevelConfig;
use crate::env::world::Action;
use crate::episode::{ActionMode, EpisodeRequest, EpisodeSpec};
use crate::metrics::MetricsError;

/// A Python policy's episode as its report recorded it: replayed read-only from its level,
/// seed and actions ([`crate::episode::replay_actions`]), the policy itself not run — it is a
/// callable of the session that evaluated it, not a file — and its name never taken for a
/// checkpoint's (a policy named `bot` is not minigrid's bot).
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedEpisode {
    /// The policy's name in the report (`groundscope.evaluate(..., name=)`, `"python"` by
    /// default).
    pub policy: String,
    /// The level, in its done mode.
    pub level: LevelConfig,
    /// The level seed.
    pub seed: u64,
    /// The report's action mode (recorded; the actions are replayed, not chosen).
    pub mode: ActionMode,
    /// The step it opens at ([`EpisodeRow::open_step`]).
    pub step: usize,
    /// The actions it took, in order.
    pub actions: Vec<Action>,
}

impl RecordedEpisode {
    /// The line that says what is shown: `python policy 'NAME': read-only, its episodes are
    /// replayed from the report`.
    pub fn line(&self) -> String {
        read_only_line(&self.policy)
    }

    /// The trace's name of its policy: `python policy 'NAME'`, which no checkpoint is named.
    pub fn label(&self) -> String {
        format!("python policy '{}'", self.policy)
    }

    /// What replays it: its level, seed and mode, with the level's own mission.
    pub fn spec(&self) -> EpisodeSpec {
        EpisodeSpec {
            level: self.level,
            seed: self.seed,
            mission: None,
            mode: self.mode,
        }
    }
}

/// The one line the debugger shows over a Python policy's episode.
pub fn read_only_line(policy: &str) -> String {
    format!("python policy '{policy}': read-only, its episodes are replayed from the report")
}

/// An evaluation's episodes as `eval --out DIR` wrote them.
#[derive(Clone, Debug)]
pub struct ReportEpisodes {
    /// The report's folder.
    pub dir: PathBuf,
    /// Every episode, in the file's order.
    pub rows: Vec<EpisodeRow>,
    /// Whether the evaluation sampled its actions (`report.json`'s `mode`).
    pub sample: bool,
    /// The checkpoints `report.json` lists as Python policies (`groundscope.evaluate`): their
    /// episodes cannot be re-run, so [`Self::episode`] refuses them and [`Self::recorded`]
    /// replays them instead, and their names are never resolved as checkpoints (a policy named
    /// `bot` is not minigrid's bot).
    pub python: BTreeSet<String>,
}

impl ReportEpisodes {
    /// Reads the evaluation in `dir` (`eval --out`): `episodes.csv`, and `report.json` for the
    /// action mode (greedy where it is absent). Names the file, line and column of anything
    /// wrong.
    pub fn open(dir: &Path) -> Result<Self, MetricsError> {
        let rows = read_episodes_csv(&dir.join("episodes.csv"))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            sample: Self::sampled(dir)?,
            python: Self::python_policies(dir),
            rows,
        })
    }

    /// Whether `dir/report.json` says the actions were sampled.
    fn sampled(dir: &Path) -> Result<bool, MetricsError> {
        let path = dir.join("report.json");
        let Ok(text) = crate::files::read_regular_to_string(&path) else {
            return Ok(false);
        };
        let json: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| MetricsError::Format {
                path: path.clone(),
                field: "JSON".into(),
                reason: e.to_string(),
            })?;
        match json.get("mode").and_then(serde_json::Value::as_str) {
            None | Some("greedy") => Ok(false),
            Some("sampled" | "sample") => Ok(true),
            Some(other) => Err(MetricsError::Format {
                path,
                field: "mode".into(),
                reason: format!("{other:?} is not greedy or sampled"),
            }),
        }
    }

    /// The names of the checkpoints `dir/report.json` lists as Python policies: marked
    /// `python`, or — in a report written before that field — with a `null` level and a
    /// kind other than `bot` (`eval` records the level of every checkpoint it loads but the
    /// bot's), or named `bot` with another kind. None without a readable report.json (its
    /// errors are [`Self::sampled`]'s).
    fn python_policies(dir: &Path) -> BTreeSet<String> {
        let Ok(text) = crate::files::read_regular_to_string(&dir.join("report.json")) else {
            return BTreeSet::new();
        };
        let Ok(json) = serde_json::from_str::<serde_json::Value>(&text) else {
            return BTreeSet::new();
        };
        let is_python = |c: &serde_json::Value| {
            let variant = c.get("variant").and_then(serde_json::Value::as_str);
            let name = c.get("name").and_then(serde_json::Value::as_str);
            match c.get("python").and_then(serde_json::Value::as_bool) {
                Some(python) => python,
                None => {
                    variant != Some("bot")
                        && (c.get("level").is_some_and(serde_json::Value::is_null)
                            || name == Some("bot"))
                }
            }
        };
        json.get("checkpoints")
            .and_then(serde_json::Value::as_array)
            .into_iter()
            .flatten()
            .filter(|c| is_python(c))
            .filter_map(|c| c.get("name").and_then(serde_json::Value::as_str))
            .map(str::to_owned)
            .collect()
    }

    /// Row `i`, or an error naming the report.
    fn row(&self, i: usize) -> Result<&EpisodeRow, MetricsError> {
        self.rows.get(i).ok_or_else(|| {
            MetricsError::Invalid(format!("no episode {i} in {}", self.dir.display()))
        })
    }

    /// Whether row `i` is a Python policy's episode: it opens read-only ([`Self::recorded`]),
    /// never through [`Self::episode`].
    pub fn is_python(&self, i: usize) -> bool {
        self.rows
            .get(i)
            .is_some_and(|r| self.python.contains(&r.checkpoint))
    }

    /// The sampling the report's episodes ran with.
    fn mode(&self) -> ActionMode {
        if self.sample {
            ActionMode::Sampled
        } else {
            ActionMode::Greedy
        }
    }

    /// What replays row `i`, a Python policy's episode, read-only: its level in its done mode,
    /// seed, the report's sampling, the step to open at and the actions of its `actions`
    /// column. Refuses a checkpoint's row (it opens with [`Self::episode`]) and a row whose
    /// actions are missing or not actions, naming `episodes.csv`'s line.
    pub fn recorded(&self, i: usize) -> Result<RecordedEpisode, MetricsError> {
        let row = self.row(i)?;
        if !self.python.contains(&row.checkpoint) {
            return Err(MetricsError::Invalid(format!(
                "{}: {:?} is a checkpoint, not a Python policy: its episodes are re-run, not replayed",
                self.dir.display(),
                row.checkpoint
            )));
        }
        let bad = |reason: String| MetricsError::Format {
            path: self.dir.join("episodes.csv"),
            field: format!("line {}, column actions", i + 2),
            reason,
        };
        let actions = row
            .actions
            .split_whitespace()
            .map(|a| {
                a.parse::<usize>()
                    .ok()
                    .and_then(Action::from_index)
                    .ok_or_else(|| bad(format!("{a:?} is not an action (0–6)")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        if actions.len() != row.steps as usize {
            return Err(bad(format!(
                "{} actions for an episode of {} steps: its episode cannot be replayed",
                actions.len(),
                row.steps
            )));
        }
        Ok(RecordedEpisode {
            policy: row.checkpoint.clone(),
            level: Self::level_of(row)?,
            seed: row.level_seed,
            mode: self.mode(),
            step: row.open_step(),
            actions,
        })
    }

    /// Row `row`'s level, in the done mode it ran in.
    fn level_of(row: &EpisodeRow) -> Result<LevelConfig, MetricsError> {
        Ok(LevelConfig {
            done_required: row.done_required,
            ..LevelConfig::from_id(&row.level).map_err(|e| MetricsError::Invalid(e.to_string()))?
        })
    }

    /// What opens row `i`: its checkpoint resolved from here, its level in its done mode, its
    /// seed, the report's sampling and the step to open at ([`EpisodeRow::open_step`]). A
    /// Python policy's row is refused: it is replayed read-only ([`Self::recorded`]).
    pub fn episode(&self, i: usize) -> Result<EpisodeRequest, MetricsError> {
        let row = self.row(i)?;
        if self.python.contains(&row.checkpoint) {
            return Err(MetricsError::Invalid(format!(
                "{}: {:?} is a Python policy (groundscope.evaluate), not a checkpoint: its episodes cannot be re-run here; record one from Python with groundscope.record(act, \"{}\", {}, \"episode.rrd\") and open it with rerun",
                self.dir.display(),
                row.checkpoint,
                row.level,
                row.level_seed
            )));
        }
        Ok(EpisodeRequest {
            checkpoint: self.resolve(&row.checkpoint),
            level: Self::level_of(row)?,
            seed: row.level_seed,
            mode: self.mode(),
            step: row.open_step(),
            mission: None,
        })
    }

    /// The first failure in the file (else the first episode): where the debugger opens a
    /// report.
    pub fn first(&self) -> Option<usize> {
        self.rows
            .iter()
            .position(|r| !r.success)
            .or_else(|| (!self.rows.is_empty()).then_some(0))
    }

    /// A checkpoint name that loads from here: as the evaluation named it where it does
    /// (`bundled:…`, `bot`, a path that exists), else the same path from the report's folder
    /// or the folder above it (an `eval --out` run elsewhere with a relative path).
    fn resolve(&self, name: &str) -> String {
        let exists = |p: &Path| {
            p.exists()
                || p.with_extension("json").exists()
                || Path::new(&format!("{}.json", p.display())).exists()
        };
        if name.starts_with(crate::policy::bundled::PREFIX)
            || name == "bot"
            || exists(Path::new(name))
        {
            return name.to_owned();
        }
        [Some(self.dir.as_path()), self.dir.parent()]
            .into_iter()
            .flatten()
            .map(|d| d.join(name))
            .find(|p| exists(p))
            .map_or_else(|| name.to_owned(), |p| p.display().to_string())
    }
}
