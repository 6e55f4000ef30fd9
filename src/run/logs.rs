//! A run's two logs, `log.csv` (a row per update) and `eval_log.csv` (the tracked evaluation):
//! their headers, the rows a warm start carries over from its parent, and the rows a resume
//! keeps.

use std::path::Path;

use super::{RunDir, RunError};
use crate::metrics::tracking::{EVAL_LOG_HEADER, EVAL_LOG_HEADER_V1};
use crate::policy::ppo::{Trainer, UpdateLog};

/// `log.csv`'s header.
pub const LOG_HEADER: &str = "update,frames,fps,episodes,success_rate,mean_reward,mean_length,policy_loss,value_loss,entropy,grad_norm,elapsed_secs";

/// A row of `log.csv` as a reader of a run's progress (a study's runner) sees it: its columns
/// read by their names in the header, never by their places, so a column added or moved is
/// still read right.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
pub struct LogRow {
    /// The update.
    pub update: u64,
    /// Frames trained so far.
    pub frames: u64,
    /// Frames per second since the process started the run.
    pub fps: f64,
}

/// The last complete row of the training log at `path`; `None` where it cannot be read or
/// holds no row yet. A row still being appended (fewer fields than the header) is skipped.
pub fn last_row(path: &Path) -> Option<LogRow> {
    let file = std::fs::File::open(path).ok()?;
    csv::Reader::from_reader(file)
        .deserialize::<LogRow>()
        .filter_map(Result::ok)
        .last()
}

/// `log.csv`'s row for one update, `fps` and `elapsed` seconds measured by the run.
pub(super) fn update_row(log: &UpdateLog, fps: f64, elapsed: f64) -> String {
    let row = crate::table::Record::new()
        .field(log.update)
        .field(log.frames)
        .field(format!("{fps:.0}"))
        .field(log.episodes)
        .field(format!("{:.4}", log.success_rate))
        .field(format!("{:.4}", log.mean_reward))
        .field(format!("{:.2}", log.mean_length))
        .field(format!("{:.5}", log.policy_loss))
        .field(format!("{:.5}", log.value_loss))
        .field(format!("{:.4}", log.entropy))
        .field(format!("{:.4}", log.grad_norm))
        .field(format!("{elapsed:.1}"));
    crate::table::line(&row)
}

/// A new run's two logs in `dir`: their headers, and a warm start's `parent`'s rows up to its
/// update, so its log and learning curve start at frame 0.
pub(super) fn write_fresh(
    dir: &mut RunDir,
    parent: Option<&str>,
    trainer: &Trainer,
) -> Result<(), RunError> {
    let u = trainer.state.updates;
    let rows = |file: &str, header: &str| {
        parent.map_or_else(String::new, |name| parent_rows(name, file, header, u))
    };
    let (log, evals) = (
        rows("log.csv", LOG_HEADER),
        rows("eval_log.csv", EVAL_LOG_HEADER),
    );
    let path = dir.path().to_path_buf();
    dir.write_log(&path.join("log.csv"), &format!("{LOG_HEADER}\n{log}"))?;
    dir.write_log(
        &path.join("eval_log.csv"),
        &format!("{EVAL_LOG_HEADER}\n{evals}"),
    )
}

/// The rows of the log `file` beside checkpoint `name` up to `updates`, so a warm-started
/// run's log and learning curve start at frame 0. Empty when there is no such log.
fn parent_rows(name: &str, file: &str, header: &str, updates: u64) -> String {
    if name.starts_with(crate::policy::bundled::PREFIX) {
        return String::new();
    }
    // The logs sit beside the checkpoint (inside a run directory given as the name).
    let name = crate::policy::checkpoint::checkpoint_name(Path::new(name));
    let dir = name.parent().unwrap_or(Path::new("."));
    rows_upto(&dir.join(file), header, updates)
}

/// The rows of training log `path` for updates `1..=updates` (none when it is missing or not
/// a training log).
fn rows_upto(path: &Path, header: &str, updates: u64) -> String {
    let Ok(text) = std::fs::read_to_string(path) else {
        return String::new();
    };
    let mut lines = text.lines();
    // An eval_log.csv written before it named the level gains an empty `level` field.
    let pad = match lines.next() {
        Some(h) if h == header => "",
        Some(h) if h == EVAL_LOG_HEADER_V1 && header == EVAL_LOG_HEADER => ",",
        _ => return String::new(),
    };
    let mut rows = String::new();
    for line in lines {
        match line.split(',').next().and_then(|u| u.parse::<u64>().ok()) {
            Some(u) if u <= updates => {
                rows.push_str(line);
                rows.push_str(pad);
                rows.push('\n');
            }
            _ => break,
        }
    }
    rows
}

/// The rows of a resumed run's log `path` for updates `1..=updates`, refusing a log that does
/// not match the checkpoint: missing, not a regular file (a FIFO would block the read), not a
/// training log, a row that is not one (garbage, a line cut short inside the file), or — for
/// `log.csv` (`every_update`) — updates that do not run one by one up to the checkpoint's (a
/// deleted row, a short log): [`RunError::BadLog`]. The last line alone may be cut short: a
/// crash while it was being appended leaves it so, and its update is one the checkpoint does
/// not hold (a run killed between checkpoints has logged updates the resume does again).
pub(super) fn resumed_rows(
    path: &Path,
    header: &str,
    updates: u64,
    every_update: bool,
) -> Result<String, RunError> {
    let shown = path.display();
    let bad = |what: String| RunError::BadLog {
        path: path.to_path_buf(),
        what,
    };
    let text =
        crate::files::read_regular_to_string(path).map_err(|e| bad(format!("{shown}: {e}")))?;
    let mut lines: Vec<&str> = text.split('\n').collect();
    // What follows the last newline: empty, or a row cut short by a crash.
    lines.pop();
    let mut lines = lines.into_iter().enumerate();
    let pad = match lines.next() {
        Some((_, h)) if h == header => "",
        Some((_, h)) if h == EVAL_LOG_HEADER_V1 && header == EVAL_LOG_HEADER => ",",
        _ => {
            return Err(bad(format!(
                "{shown} is not a training log (its header is not {header:?})"
            )));
        }
    };
    let fields = header.split(',').count() - pad.len();
    let mut rows = String::new();
    let mut last = None;
    for (i, line) in lines {
        let update = line
            .split(',')
            .next()
            .and_then(|u| u.parse::<u64>().ok())
            .filter(|_| line.split(',').count() == fields);
        let Some(update) = update else {
            return Err(bad(format!("{shown} line {}: not a row of the log", i + 1)));
        };
        if update > updates {
            break;
        }
        let in_order = match last {
            None => true,
            Some(l) if every_update => update == l + 1,
            Some(l) => update >= l,
        };
        if !in_order {
            return Err(bad(format!(
                "{shown} line {}: update {update} follows update {}; the log does not match the checkpoint",
                i + 1,
                last.unwrap_or(0)
            )));
        }
        last = Some(update);
        rows.push_str(line);
        rows.push_str(pad);
        rows.push('\n');
    }
    if every_update && updates > 0 && last != Some(updates) {
        return Err(bad(format!(
            "{shown} ends at update {}, and the checkpoint is at update {updates}; the log does not match it",
            last.unwrap_or(0)
        )));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_row_is_read_by_column_name_and_a_row_cut_short_is_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.csv");
        // The columns in another order than LOG_HEADER's, and a last row cut short.
        std::fs::write(
            &path,
            "fps,frames,update,episodes\n100,2048,1,3\n250,4096,2,7\n99,61",
        )
        .unwrap();
        assert_eq!(
            last_row(&path),
            Some(LogRow {
                update: 2,
                frames: 4096,
                fps: 250.0
            })
        );
        std::fs::write(&path, format!("{LOG_HEADER}\n")).unwrap();
        assert_eq!(last_row(&path), None);
        assert_eq!(last_row(&dir.path().join("missing.csv")), None);
    }
}
