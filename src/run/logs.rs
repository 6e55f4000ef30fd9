//! A run's two logs, `log.csv` (a row per update) and `eval_log.csv` (the tracked evaluation):
//! their headers, the rows a warm start carries over from its parent, and the rows a resume
//! keeps.

use std::path::Path;

use crate::metrics::tracking::EVAL_LOG_HEADER_V1;
use crate::policy::ppo::UpdateLog;

/// `log.csv`'s header.
pub const LOG_HEADER: &str = "update,frames,fps,episodes,success_rate,mean_reward,mean_length,policy_loss,value_loss,entropy,grad_norm,elapsed_secs";

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

/// The rows of the log `file` beside checkpoint `name` up to `updates`, so a warm-started
/// run's log and learning curve start at frame 0. Empty when there is no such log.
pub(super) fn parent_rows(name: &str, file: &str, header: &str, updates: u64) -> String {
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
        Some(h)
            if h == EVAL_LOG_HEADER_V1 && header == crate::metrics::tracking::EVAL_LOG_HEADER =>
        {
            ","
        }
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
/// deleted row, a short log). The last line alone may be cut short: a crash while it was
/// being appended leaves it so, and its update is one the checkpoint does not hold (a run
/// killed between checkpoints has logged updates the resume does again).
pub(super) fn resumed_rows(
    path: &Path,
    header: &str,
    updates: u64,
    every_update: bool,
) -> anyhow::Result<String> {
    let shown = path.display();
    let fix = "restore it, or start a new run from this one's weights with --init";
    let text = crate::files::read_regular_to_string(path)
        .map_err(|e| anyhow::anyhow!("{shown}: {e}; {fix}"))?;
    let mut lines: Vec<&str> = text.split('\n').collect();
    // What follows the last newline: empty, or a row cut short by a crash.
    lines.pop();
    let mut lines = lines.into_iter().enumerate();
    let pad = match lines.next() {
        Some((_, h)) if h == header => "",
        Some((_, h))
            if h == EVAL_LOG_HEADER_V1 && header == crate::metrics::tracking::EVAL_LOG_HEADER =>
        {
            ","
        }
        _ => anyhow::bail!("{shown} is not a training log (its header is not {header:?}); {fix}"),
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
            anyhow::bail!("{shown} line {}: not a row of the log; {fix}", i + 1);
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
            anyhow::bail!(
                "{shown} line {}: update {update} follows update {}; the log does not match the checkpoint; {fix}",
                i + 1,
                last.unwrap_or(0)
            );
        }
        last = Some(update);
        rows.push_str(line);
        rows.push_str(pad);
        rows.push('\n');
    }
    if every_update && updates > 0 && last != Some(updates) {
        anyhow::bail!(
            "{shown} ends at update {}, and the checkpoint is at update {updates}; the log does not match it; {fix}",
            last.unwrap_or(0)
        );
    }
    Ok(rows)
}
