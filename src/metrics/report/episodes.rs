//! `episodes.csv`: every episode of an evaluation on one line, so that it can be lined up with
//! another evaluation of the same levels and seeds (`export/eval_in_python.py`) and reopened in
//! the debugger (`view --report`). One row is one [`EpisodeRow`], written and read through serde
//! with the same type, so that the writer and the reader cannot disagree on a column.

use std::path::Path;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::env::level::LevelConfig;
use crate::metrics::error::MetricsError;
use crate::metrics::failure::{FailureClass, decisive_step};
use crate::metrics::sweep::EpisodeSummary;
use crate::table::Table;

/// `episodes.csv`'s header: [`EpisodeRow`]'s fields, in order (a unit test holds them equal).
pub const EPISODES_CSV_HEADER: &str = "checkpoint,level,eval_seed,episode,level_seed,mission,success,steps,return,failure_class,actions,expert_agreement,first_divergence,bot_steps,path_efficiency,behaviour,done_required,decisive_step";

/// The columns a file must have to be read back; the others may be missing from files older
/// than them (and from hand-made ones), and read as empty.
pub const EPISODES_CSV_REQUIRED: [&str; 5] =
    ["checkpoint", "level", "level_seed", "success", "steps"];

/// One row of `episodes.csv`: one episode, its outcome, and the same episode beside
/// minigrid's bot. Numbers are written as they always were: integers as they display, `success`
/// and `done_required` as 0 / 1, `return` and the bot's ratios with six decimals, a missing
/// value as an empty field.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EpisodeRow {
    /// The checkpoint as the evaluation named it.
    pub checkpoint: String,
    /// The level id ([`LevelConfig::id`]).
    pub level: String,
    /// The evaluation seed.
    pub eval_seed: u64,
    /// The episode's index within its evaluation seed.
    pub episode: u64,
    /// The level seed (replays the episode).
    pub level_seed: u64,
    /// The mission.
    pub mission: String,
    /// Whether it succeeded.
    #[serde(serialize_with = "write_flag", deserialize_with = "read_flag")]
    pub success: bool,
    /// Its length in steps.
    pub steps: u32,
    /// Its return (NaN where the file has none).
    #[serde(
        rename = "return",
        default = "no_return",
        serialize_with = "write_fixed",
        deserialize_with = "read_return"
    )]
    pub ret: f64,
    /// A failure's class (empty for a success).
    pub failure_class: String,
    /// The actions taken, as indices separated by spaces.
    pub actions: String,
    /// The share of steps at which the agent took the bot's action (`None`: the bot had none).
    #[serde(serialize_with = "write_fixed_or_empty")]
    pub expert_agreement: Option<f64>,
    /// The first divergence from the bot that mattered (`None`: never, or not recorded).
    pub first_divergence: Option<u32>,
    /// The bot's own length from the same start, where it succeeded alone.
    pub bot_steps: Option<u32>,
    /// The bot's steps over the agent's on a success (`None` otherwise).
    #[serde(serialize_with = "write_fixed_or_empty")]
    pub path_efficiency: Option<f64>,
    /// A failure's behaviour (empty: none, or a success).
    pub behaviour: String,
    /// Whether it ran in the done-action mode.
    #[serde(serialize_with = "write_flag", deserialize_with = "read_flag")]
    pub done_required: bool,
    /// Where a failure was lost (`None` for a success, or in files older than the column).
    pub decisive_step: Option<u32>,
}

impl EpisodeRow {
    /// The row of episode `e`, the `index`-th of its evaluation seed, of `checkpoint` on
    /// `level`.
    pub fn of(checkpoint: &str, level: &LevelConfig, index: u64, e: &EpisodeSummary) -> Self {
        let x = &e.expert;
        let finite = |v: f64| Some(v).filter(|v| v.is_finite());
        let actions: Vec<String> = e.actions.iter().map(u8::to_string).collect();
        Self {
            checkpoint: checkpoint.to_owned(),
            level: level.id(),
            eval_seed: e.eval_seed,
            episode: index,
            level_seed: e.level_seed,
            mission: e.mission.clone(),
            success: e.success,
            steps: e.length,
            ret: e.reward,
            failure_class: e.failure.map_or("", |d| d.class.name()).to_owned(),
            actions: actions.join(" "),
            expert_agreement: finite(x.agreement()),
            first_divergence: x.first_divergence,
            bot_steps: x.bot_length,
            path_efficiency: finite(x.path_efficiency(e.success, e.length)),
            behaviour: e
                .failure
                .and_then(|d| d.behaviour)
                .map_or("", FailureClass::name)
                .to_owned(),
            done_required: level.done_required,
            decisive_step: e
                .failure
                .map(|d| decisive_step(d.lost_at, x.first_divergence, e.length)),
        }
    }

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

/// `episodes.csv`: one line per episode of every cell, in sweep order (cells as evaluated,
/// then evaluation seed, then episode): the level, its seed, the mission, the outcome, the
/// failure class, the actions taken (indices, space-separated), the episode beside the bot,
/// the done mode it ran in (`done_required`: 1 where 'done' had to end it) and, for a failure,
/// the step it opens at ([`crate::metrics::failure::decisive_step`]).
pub fn episodes_csv(cells: &[(String, LevelConfig, Vec<EpisodeSummary>)]) -> String {
    let mut t = Table::new(EPISODES_CSV_HEADER);
    for (checkpoint, level, eps) in cells {
        let mut index = 0u64;
        let mut seed = None;
        for e in eps {
            if seed != Some(e.eval_seed) {
                (seed, index) = (Some(e.eval_seed), 0);
            }
            t.serialize(&EpisodeRow::of(checkpoint, level, index, e));
            index += 1;
        }
    }
    t.finish()
}

/// Reads `episodes.csv` at `path` back, every row checked: the columns the debugger needs
/// present, every field of its column's type and every level one some version wrote. Names the
/// file, line and column of anything wrong.
pub fn read_episodes_csv(path: &Path) -> Result<Vec<EpisodeRow>, MetricsError> {
    let text = crate::files::read_regular_to_string(path).map_err(|e| MetricsError::Io {
        path: path.to_path_buf(),
        reason: format!("{e} (`view --report` takes the folder `eval --out` wrote)"),
    })?;
    let (header, records) = crate::table::read(&text).map_err(|reason| MetricsError::Format {
        path: path.to_path_buf(),
        field: "CSV".into(),
        reason,
    })?;
    for need in EPISODES_CSV_REQUIRED {
        if !header.iter().any(|h| h == need) {
            return Err(MetricsError::Format {
                path: path.to_path_buf(),
                field: need.into(),
                reason: "column missing from the header".into(),
            });
        }
    }
    let mut rows = Vec::with_capacity(records.len());
    for (i, cells) in records.iter().enumerate() {
        let line = i + 2;
        let row: EpisodeRow = crate::table::deserialize(&header, cells).map_err(|e| {
            let field = e.column.as_ref().map_or_else(
                || format!("line {line}"),
                |c| format!("line {line} column {c}"),
            );
            let reason = match (&e.column, &e.value) {
                (Some(c), Some(v)) if e.unparsed => format!("{v:?} is not {}", wanted(c)),
                _ => e.reason,
            };
            MetricsError::Format {
                path: path.to_path_buf(),
                field,
                reason,
            }
        })?;
        // The level must open: an id no version of the tool wrote is named here, not later.
        LevelConfig::from_id(&row.level).map_err(|e| MetricsError::Format {
            path: path.to_path_buf(),
            field: format!("line {line} column level"),
            reason: e.to_string(),
        })?;
        rows.push(row);
    }
    Ok(rows)
}

/// What a column's text must read as, for an error message.
fn wanted(column: &str) -> &'static str {
    match column {
        "success" | "done_required" => "0 or 1",
        "return" | "expert_agreement" | "path_efficiency" => "a number",
        _ => "a whole number",
    }
}

/// A flag as 0 or 1.
#[expect(
    clippy::trivially_copy_pass_by_ref,
    reason = "serde's serialize_with passes the field by reference"
)]
fn write_flag<S: Serializer>(v: &bool, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u8(u8::from(*v))
}

/// A flag from 1 (true), or 0 or an empty field (false).
fn read_flag<'de, D: Deserializer<'de>>(d: D) -> Result<bool, D::Error> {
    match Option::<u8>::deserialize(d)? {
        None | Some(0) => Ok(false),
        Some(1) => Ok(true),
        Some(v) => Err(serde::de::Error::custom(format!("\"{v}\" is not 0 or 1"))),
    }
}

/// A number with six decimals.
#[expect(
    clippy::trivially_copy_pass_by_ref,
    reason = "serde's serialize_with passes the field by reference"
)]
fn write_fixed<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{v:.6}"))
}

/// A number with six decimals, or an empty field.
#[expect(
    clippy::ref_option,
    reason = "serde's serialize_with passes the field by reference"
)]
fn write_fixed_or_empty<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(v) => write_fixed(v, s),
        None => s.serialize_none(),
    }
}

/// A return: a number, or NaN where the field is empty.
fn read_return<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// The return of a file without the column.
fn no_return() -> f64 {
    f64::NAN
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row() -> EpisodeRow {
        EpisodeRow {
            checkpoint: "runs/a,b".into(),
            level: "BabyAI-GoToLocal-v0".into(),
            eval_seed: 1000,
            episode: 2,
            level_seed: 1_000_000_002,
            mission: "go to the red ball".into(),
            success: false,
            steps: 64,
            ret: 0.0,
            failure_class: "timeout".into(),
            actions: "2 2 0".into(),
            expert_agreement: Some(0.5),
            first_divergence: Some(3),
            bot_steps: None,
            path_efficiency: None,
            behaviour: String::new(),
            done_required: true,
            decisive_step: Some(3),
        }
    }

    /// The serde row writes the header's columns in the header's order, and the bytes the
    /// field-by-field writer wrote before it.
    #[test]
    fn a_row_writes_the_columns_and_bytes_of_the_header() {
        let mut w = csv::WriterBuilder::new()
            .terminator(csv::Terminator::Any(b'\n'))
            .from_writer(Vec::new());
        w.serialize(row()).unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert_eq!(text.lines().next(), Some(EPISODES_CSV_HEADER));
        let mut t = Table::new(EPISODES_CSV_HEADER);
        t.serialize(&row());
        assert_eq!(
            t.finish(),
            format!(
                "{EPISODES_CSV_HEADER}\n\"runs/a,b\",BabyAI-GoToLocal-v0,1000,2,1000000002,go to the red ball,0,64,0.000000,timeout,2 2 0,0.500000,3,,,,1,3\n"
            )
        );
    }

    /// What is written reads back as the same row; a file without the later columns reads
    /// them as empty; a field of the wrong type is named by line and column.
    #[test]
    fn rows_read_back_and_bad_fields_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("episodes.csv");
        let mut t = Table::new(EPISODES_CSV_HEADER);
        t.serialize(&row());
        std::fs::write(&path, t.finish()).unwrap();
        assert_eq!(read_episodes_csv(&path).unwrap(), vec![row()]);
        std::fs::write(
            &path,
            "checkpoint,level,level_seed,mission,success,steps\nbot,BabyAI-GoToLocal-v0,3,go to the red ball,1,5\n",
        )
        .unwrap();
        let old = &read_episodes_csv(&path).unwrap()[0];
        assert!(old.success && old.ret.is_nan() && old.decisive_step.is_none());
        assert_eq!(old.open_step(), 0);
        for (bad, field, reason) in [
            (
                "x,m,1,5",
                "line 2 column level_seed",
                "\"x\" is not a whole number",
            ),
            ("3,m,x,5", "line 2 column success", "\"x\" is not 0 or 1"),
        ] {
            std::fs::write(
                &path,
                format!("checkpoint,level,level_seed,mission,success,steps\nbot,BabyAI-GoToLocal-v0,{bad}\n"),
            )
            .unwrap();
            let e = read_episodes_csv(&path).unwrap_err().to_string();
            assert!(e.contains(field) && e.contains(reason), "{e}");
        }
    }
}
