//! The episodes panel's model (`view --report DIR`): which of an evaluation's episodes are
//! listed (the filters), in what order (the sort), which one is open, whether the list is
//! shown or folded away, and N / P from failure to failure. No UI here: the panel
//! ([`super::ui`]) draws what this decides; reading the report is [`ReportEpisodes`]'s.

use std::cmp::Ordering;
use std::collections::BTreeSet;
use std::path::Path;

use crate::episode::EpisodeRequest;
use crate::metrics::MetricsError;
use crate::metrics::report::EpisodeRow;
use crate::metrics::report::browse::{RecordedEpisode, ReportEpisodes};

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

/// An evaluation's episodes, filtered and sorted as the panel lists them.
#[derive(Clone, Debug)]
pub struct Browser {
    /// The evaluation, as read.
    pub report: ReportEpisodes,
    /// The filters.
    pub filter: Filter,
    /// The sort column and whether it ascends; `None`: the file's order.
    pub sort: Option<(Column, bool)>,
    /// The episode open now (an index into the report's rows).
    pub selected: Option<usize>,
    /// Whether the list is shown; false once an episode has been picked from it (the panel
    /// folds to one line, out of the way of the episode it opened).
    pub listed: bool,
    shown: Vec<usize>,
}

impl Browser {
    /// Reads the evaluation in `dir` ([`ReportEpisodes::open`]), every episode listed in the
    /// file's order, none selected.
    pub fn open(dir: &Path) -> Result<Self, MetricsError> {
        Ok(Self::new(ReportEpisodes::open(dir)?))
    }

    /// Lists the episodes of `report`, every one in the file's order, none selected.
    pub fn new(report: ReportEpisodes) -> Self {
        let mut me = Self {
            report,
            filter: Filter::default(),
            sort: None,
            selected: None,
            listed: true,
            shown: Vec::new(),
        };
        me.refresh();
        me
    }

    /// The failures among every row.
    pub fn failed(&self) -> usize {
        self.report.rows.iter().filter(|r| !r.success).count()
    }

    /// What opens row `i` ([`ReportEpisodes::episode`]).
    pub fn episode(&self, i: usize) -> Result<EpisodeRequest, MetricsError> {
        self.report.episode(i)
    }

    /// Whether row `i` is a Python policy's, replayed read-only ([`ReportEpisodes::is_python`]).
    pub fn is_python(&self, i: usize) -> bool {
        self.report.is_python(i)
    }

    /// What replays row `i`, a Python policy's ([`ReportEpisodes::recorded`]).
    pub fn recorded(&self, i: usize) -> Result<RecordedEpisode, MetricsError> {
        self.report.recorded(i)
    }

    /// The first failure in the file, else its first episode ([`ReportEpisodes::first`]).
    pub fn first(&self) -> Option<usize> {
        self.report.first()
    }

    /// Row `i` picked from the list: selected, and the list folded away.
    pub fn pick(&mut self, i: usize) {
        self.selected = Some(i);
        self.listed = false;
    }

    /// Recomputes the list after a change of filter or sort.
    pub fn refresh(&mut self) {
        let mut shown: Vec<usize> = (0..self.report.rows.len())
            .filter(|&i| self.filter.passes(&self.report.rows[i]))
            .collect();
        if let Some((col, ascending)) = self.sort {
            // Stable: ties keep the file's order.
            shown.sort_by(|&a, &b| {
                let o = col.compare(&self.report.rows[a], &self.report.rows[b]);
                if ascending { o } else { o.reverse() }
            });
        }
        self.shown = shown;
    }

    /// The rows listed, in order (indices into the report's rows).
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
        self.report
            .rows
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
            .find(|&i| !self.report.rows[i].success)?;
        self.selected = Some(next);
        Some(next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(level: &str, seed: u64, success: bool, steps: u32) -> EpisodeRow {
        EpisodeRow {
            checkpoint: "bundled:babyai".into(),
            level: level.into(),
            level_seed: seed,
            success,
            steps,
            decisive_step: (!success).then_some(steps / 2),
            ..EpisodeRow::default()
        }
    }

    fn browser() -> Browser {
        Browser::new(ReportEpisodes {
            dir: "report".into(),
            rows: vec![
                row("BabyAI-GoToLocal-v0", 1, false, 64),
                row("BabyAI-GoToLocal-v0", 2, true, 9),
                row("BabyAI-GoToDoor-v0", 1, false, 30),
                row("BabyAI-GoToDoor-v0", 2, false, 12),
            ],
            sample: false,
            python: BTreeSet::new(),
        })
    }

    /// A pick selects the row and folds the list; N / P select without folding it.
    #[test]
    fn a_pick_folds_the_list_and_n_and_p_do_not() {
        let mut b = browser();
        assert!(b.listed);
        assert_eq!(b.step_failure(true), Some(0));
        assert!(b.listed);
        b.pick(2);
        assert_eq!((b.selected, b.listed), (Some(2), false));
        assert_eq!(b.step_failure(true), Some(3));
        assert_eq!(b.step_failure(true), Some(0));
        assert_eq!(b.step_failure(false), Some(3));
    }

    /// Filters narrow the list, sorts order it (a second click the other way), and a
    /// failure's episode opens at its decisive step.
    #[test]
    fn filters_and_sorts_decide_the_list() {
        let mut b = browser();
        b.filter.outcome = Outcome::Failures;
        b.refresh();
        assert_eq!(b.shown(), [0, 2, 3]);
        b.sort_by(Column::Steps);
        assert_eq!(b.shown(), [3, 2, 0]);
        b.sort_by(Column::Steps);
        assert_eq!(b.shown(), [0, 2, 3]);
        b.filter.level = Some("BabyAI-GoToDoor-v0".into());
        b.refresh();
        assert_eq!(b.shown(), [2, 3]);
        assert_eq!(
            b.values(Column::Level),
            ["BabyAI-GoToDoor-v0", "BabyAI-GoToLocal-v0"]
        );
        assert_eq!(b.episode(0).unwrap().step, 32);
    }
}
