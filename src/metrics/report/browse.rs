//! An evaluation read back for browsing (`view --report DIR`): its episodes (`episodes.csv`)
//! and the action mode they ran in (`report.json`), each episode with what reopens it —
//! checkpoint, level in its done mode, seed, sampling and the step to open at — and the
//! filters, sorting and failure-to-failure moves of the debugger's episodes panel. No UI here:
//! the panel draws what this decides.

use std::cmp::Ordering;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::env::level::LevelConfig;
use crate::metrics::MetricsError;

/// One row of `episodes.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct EpisodeRow {
    /// The checkpoint as the evaluation named it.
    pub checkpoint: String,
    /// The level id (`LevelConfig::id`).
    pub level: String,
    /// The level seed.
    pub level_seed: u64,
    /// The mission.
    pub mission: String,
    /// Whether it succeeded.
    pub success: bool,
    /// Its length in steps.
    pub steps: u32,
    /// Its return.
    pub ret: f64,
    /// A failure's class (empty for a success).
    pub failure_class: String,
    /// A failure's behaviour (empty: none, or a success).
    pub behaviour: String,
    /// The first divergence from the bot that mattered (`None`: never, or not recorded).
    pub first_divergence: Option<u32>,
    /// Where a failure was lost (`None` for a success, or in files older than the column).
    pub decisive_step: Option<u32>,
    /// Whether it ran in the done-action mode.
    pub done_required: bool,
}

impl EpisodeRow {
    /// The step the episode opens at: a failure's decisive step (its last step in older
    /// files), a success's first.
    pub fn open_step(&self) -> usize {
        if self.success {
            0
        } else {
            self.decisive_step
                .unwrap_or_else(|| self.steps.saturating_sub(1)) as usize
        }
    }
}

/// What opens one episode of a report in the debugger.
#[derive(Clone, Debug, PartialEq)]
pub struct OpenEpisode {
    /// The checkpoint, as a name that loads from here (resolved against the report's folder
    /// where the name the evaluation used does not).
    pub checkpoint: String,
    /// The level in the episode's done mode.
    pub level: LevelConfig,
    /// The level seed.
    pub seed: u64,
    /// Whether its actions were sampled.
    pub sample: bool,
    /// The step to open at ([`EpisodeRow::open_step`]).
    pub step: usize,
}

/// The columns the panel shows and sorts by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Column {
    /// Checkpoint.
    Checkpoint,
    /// Level id.
    Level,
    /// Level seed.
    Seed,
    /// Success or failure.
    Outcome,
    /// Length.
    Steps,
    /// Return.
    Return,
    /// Failure class.
    Class,
    /// Behaviour.
    Behaviour,
    /// First divergence that mattered.
    Diverge,
    /// The step it opens at.
    Open,
}

impl Column {
    /// Every column, in the panel's order.
    pub const ALL: [Self; 10] = [
        Self::Level,
        Self::Seed,
        Self::Outcome,
        Self::Steps,
        Self::Return,
        Self::Class,
        Self::Behaviour,
        Self::Diverge,
        Self::Open,
        Self::Checkpoint,
    ];

    /// Its header.
    pub fn name(self) -> &'static str {
        match self {
            Self::Checkpoint => "checkpoint",
            Self::Level => "level",
            Self::Seed => "seed",
            Self::Outcome => "outcome",
            Self::Steps => "steps",
            Self::Return => "return",
            Self::Class => "class",
            Self::Behaviour => "behaviour",
            Self::Diverge => "diverge",
            Self::Open => "opens at",
        }
    }

    /// `row`'s cell, as shown.
    pub fn cell(self, row: &EpisodeRow) -> String {
        let opt = |v: Option<u32>| v.map_or_else(|| "–".to_owned(), |v| v.to_string());
        match self {
            Self::Checkpoint => row.checkpoint.clone(),
            Self::Level => row.level.clone(),
            Self::Seed => row.level_seed.to_string(),
            Self::Outcome => if row.success { "success" } else { "failure" }.to_owned(),
            Self::Steps => row.steps.to_string(),
            Self::Return => format!("{:.3}", row.ret),
            Self::Class => row.failure_class.clone(),
            Self::Behaviour => row.behaviour.clone(),
            Self::Diverge => opt(row.first_divergence),
            Self::Open => row.open_step().to_string(),
        }
    }

    /// Orders two rows by this column (numbers as numbers; "never" after every step).
    fn compare(self, a: &EpisodeRow, b: &EpisodeRow) -> Ordering {
        let never = |v: Option<u32>| v.unwrap_or(u32::MAX);
        match self {
            Self::Checkpoint => a.checkpoint.cmp(&b.checkpoint),
            Self::Level => a.level.cmp(&b.level),
            Self::Seed => a.level_seed.cmp(&b.level_seed),
            Self::Outcome => a.success.cmp(&b.success),
            Self::Steps => a.steps.cmp(&b.steps),
            Self::Return => a.ret.total_cmp(&b.ret),
            Self::Class => a.failure_class.cmp(&b.failure_class),
            Self::Behaviour => a.behaviour.cmp(&b.behaviour),
            Self::Diverge => never(a.first_divergence).cmp(&never(b.first_divergence)),
            Self::Open => a.open_step().cmp(&b.open_step()),
        }
    }
}

/// Which outcomes the panel lists.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Outcome {
    /// Every episode.
    #[default]
    All,
    /// Failures only.
    Failures,
    /// Successes only.
    Successes,
}

/// Which episodes by their divergence from the bot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Divergence {
    /// Every episode.
    #[default]
    All,
    /// Those that left the bot's plan at a cost.
    Diverged,
    /// Those that never did.
    Never,
}

/// The panel's filters; `None` in a text filter lets every value through.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Filter {
    /// One checkpoint.
    pub checkpoint: Option<String>,
    /// One level.
    pub level: Option<String>,
    /// Outcome.
    pub outcome: Outcome,
    /// One failure class.
    pub class: Option<String>,
    /// One behaviour.
    pub behaviour: Option<String>,
    /// Divergence from the bot.
    pub divergence: Divergence,
}

impl Filter {
    /// Whether `row` passes.
    pub fn passes(&self, row: &EpisodeRow) -> bool {
        let is = |want: &Option<String>, got: &str| want.as_deref().is_none_or(|w| w == got);
        is(&self.checkpoint, &row.checkpoint)
            && is(&self.level, &row.level)
            && is(&self.class, &row.failure_class)
            && is(&self.behaviour, &row.behaviour)
            && match self.outcome {
                Outcome::All => true,
                Outcome::Failures => !row.success,
                Outcome::Successes => row.success,
            }
            && match self.divergence {
                Divergence::All => true,
                Divergence::Diverged => row.first_divergence.is_some(),
                Divergence::Never => row.first_divergence.is_none(),
            }
    }
}

/// An evaluation's episodes, filtered and sorted as the panel shows them.
#[derive(Clone, Debug)]
pub struct Browser {
    /// The report's folder.
    pub dir: PathBuf,
    /// Every episode, in the file's order.
    pub rows: Vec<EpisodeRow>,
    /// Whether the evaluation sampled its actions (`report.json`'s `mode`).
    pub sample: bool,
    /// The filters.
    pub filter: Filter,
    /// The sort column and whether it ascends; `None`: the file's order.
    pub sort: Option<(Column, bool)>,
    /// The episode open now (an index into `rows`).
    pub selected: Option<usize>,
    /// The checkpoints `report.json` lists as Python policies (`groundscope.evaluate`): their
    /// episodes cannot be re-run, so [`Self::episode`] refuses them, and their names are never
    /// resolved as checkpoints (a policy named `bot` is not minigrid's bot).
    pub python: BTreeSet<String>,
    shown: Vec<usize>,
}

/// `field`'s cell of `cells` under `header`, named with `path` and the line when missing.
fn cell<'a>(
    path: &Path,
    line: usize,
    header: &[String],
    cells: &'a [String],
    field: &str,
) -> Result<Option<&'a str>, MetricsError> {
    let Some(c) = header.iter().position(|h| h == field) else {
        return Ok(None);
    };
    cells
        .get(c)
        .map(|s| Some(s.as_str()))
        .ok_or_else(|| MetricsError::Format {
            path: path.to_path_buf(),
            field: format!("line {line} column {field}"),
            reason: "the line is shorter than the header".into(),
        })
}

impl Browser {
    /// Reads the evaluation in `dir` (`eval --out`): `episodes.csv`, and `report.json` for the
    /// action mode (greedy where it is absent). Names the file, line and column of anything
    /// wrong.
    pub fn open(dir: &Path) -> Result<Self, MetricsError> {
        let path = dir.join("episodes.csv");
        let text = crate::files::read_regular_to_string(&path).map_err(|e| MetricsError::Io {
            path: path.clone(),
            reason: format!("{e} (`view --report` takes the folder `eval --out` wrote)"),
        })?;
        let (header, records) =
            crate::table::read(&text).map_err(|reason| MetricsError::Format {
                path: path.clone(),
                field: "CSV".into(),
                reason,
            })?;
        for need in ["checkpoint", "level", "level_seed", "success", "steps"] {
            if !header.iter().any(|h| h == need) {
                return Err(MetricsError::Format {
                    path,
                    field: need.into(),
                    reason: "column missing from the header".into(),
                });
            }
        }
        let mut rows = Vec::with_capacity(records.len());
        for (i, cells) in records.iter().enumerate() {
            rows.push(Self::row(&path, i + 2, &header, cells)?);
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            sample: Self::sampled(dir)?,
            python: Self::python_policies(dir),
            rows,
            filter: Filter::default(),
            sort: None,
            selected: None,
            shown: Vec::new(),
        }
        .refreshed())
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

    fn row(
        path: &Path,
        line: usize,
        header: &[String],
        cells: &[String],
    ) -> Result<EpisodeRow, MetricsError> {
        let get = |f: &str| cell(path, line, header, cells, f);
        let bad = |f: &str, v: &str, want: &str| MetricsError::Format {
            path: path.to_path_buf(),
            field: format!("line {line} column {f}"),
            reason: format!("{v:?} is not {want}"),
        };
        let text = |f: &str| get(f).map(|v| v.unwrap_or("").to_owned());
        let flag = |f: &str| -> Result<bool, MetricsError> {
            match get(f)? {
                None | Some("" | "0") => Ok(false),
                Some("1") => Ok(true),
                Some(v) => Err(bad(f, v, "0 or 1")),
            }
        };
        let int = |f: &str| -> Result<Option<u64>, MetricsError> {
            match get(f)? {
                None | Some("") => Ok(None),
                Some(v) => v.parse().map(Some).map_err(|_| bad(f, v, "a whole number")),
            }
        };
        let step = |f: &str| -> Result<Option<u32>, MetricsError> {
            int(f)?
                .map(|v| u32::try_from(v).map_err(|_| bad(f, &v.to_string(), "a step")))
                .transpose()
        };
        let level = text("level")?;
        // The level must open: an id no version of the tool wrote is named here, not later.
        LevelConfig::from_id(&level).map_err(|e| MetricsError::Format {
            path: path.to_path_buf(),
            field: format!("line {line} column level"),
            reason: e.to_string(),
        })?;
        let ret = match get("return")? {
            None | Some("") => f64::NAN,
            Some(v) => v.parse().map_err(|_| bad("return", v, "a number"))?,
        };
        Ok(EpisodeRow {
            checkpoint: text("checkpoint")?,
            level,
            level_seed: int("level_seed")?.ok_or_else(|| bad("level_seed", "", "a seed"))?,
            mission: text("mission")?,
            success: flag("success")?,
            steps: step("steps")?.ok_or_else(|| bad("steps", "", "a length"))?,
            ret,
            failure_class: text("failure_class")?,
            behaviour: text("behaviour")?,
            first_divergence: step("first_divergence")?,
            decisive_step: step("decisive_step")?,
            done_required: flag("done_required")?,
        })
    }

    /// Recomputes the list after a change of filter or sort.
    pub fn refresh(&mut self) {
        let mut shown: Vec<usize> = (0..self.rows.len())
            .filter(|&i| self.filter.passes(&self.rows[i]))
            .collect();
        if let Some((col, ascending)) = self.sort {
            // Stable: ties keep the file's order.
            shown.sort_by(|&a, &b| {
                let o = col.compare(&self.rows[a], &self.rows[b]);
                if ascending { o } else { o.reverse() }
            });
        }
        self.shown = shown;
    }

    fn refreshed(mut self) -> Self {
        self.refresh();
        self
    }

    /// The rows listed, in order (indices into [`Self::rows`]).
    pub fn shown(&self) -> &[usize] {
        &self.shown
    }

    /// Sorts by `col`: ascending first, descending on a second click.
    pub fn sort_by(&mut self, col: Column) {
        self.sort = Some(match self.sort {
            Some((c, true)) if c == col => (col, false),
            _ => (col, true),
        });
        self.refresh();
    }

    /// The distinct values of a column over every row (for the filters' choices).
    pub fn values(&self, col: Column) -> Vec<String> {
        self.rows
            .iter()
            .map(|r| col.cell(r))
            .filter(|v| !v.is_empty())
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect()
    }

    /// The next failure listed after the selected row (`forward`) or before it, wrapping
    /// round; from the top (or bottom) when none is selected. Selects it.
    pub fn step_failure(&mut self, forward: bool) -> Option<usize> {
        let n = self.shown.len();
        if n == 0 {
            return None;
        }
        let at = self
            .selected
            .and_then(|s| self.shown.iter().position(|&i| i == s));
        let next = (1..=n)
            .map(|d| match (at, forward) {
                (Some(p), true) => (p + d) % n,
                (Some(p), false) => (p + n * d - d) % n,
                (None, true) => d - 1,
                (None, false) => n - d,
            })
            .map(|p| self.shown[p])
            .find(|&i| !self.rows[i].success)?;
        self.selected = Some(next);
        Some(next)
    }

    /// What opens row `i`: its checkpoint resolved from here, its level in its done mode, its
    /// seed, the report's sampling and the step to open at.
    pub fn episode(&self, i: usize) -> Result<OpenEpisode, MetricsError> {
        let row = self.rows.get(i).ok_or_else(|| {
            MetricsError::Invalid(format!("no episode {i} in {}", self.dir.display()))
        })?;
        if self.python.contains(&row.checkpoint) {
            return Err(MetricsError::Invalid(format!(
                "{}: {:?} is a Python policy (groundscope.evaluate), not a checkpoint: its episodes cannot be re-run here; record one from Python with groundscope.record(act, \"{}\", {}, \"episode.rrd\") and open it with rerun",
                self.dir.display(),
                row.checkpoint,
                row.level,
                row.level_seed
            )));
        }
        let level = LevelConfig {
            done_required: row.done_required,
            ..LevelConfig::from_id(&row.level).map_err(|e| MetricsError::Invalid(e.to_string()))?
        };
        Ok(OpenEpisode {
            checkpoint: self.resolve(&row.checkpoint),
            level,
            seed: row.level_seed,
            sample: self.sample,
            step: row.open_step(),
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
