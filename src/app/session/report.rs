//! The evaluation browsed (`view --report DIR`, or "report…" in the top bar): opening it,
//! opening its episodes (a Python policy's read-only, replayed from the report), N / P from
//! failure to failure, and comparing a second checkpoint of it on the same episode.

use std::path::Path;

use super::{AfterLoad, Session, start_load, start_replay};
use crate::app::episodes::Browser;
use crate::metrics::report::browse::RecordedEpisode;

impl Session {
    /// Opens the evaluation in `dir` in the episodes panel, listed, replacing any open one.
    pub fn open_report(&mut self, dir: &Path) {
        match Browser::open(dir) {
            Ok(b) => {
                self.info(format!(
                    "report {}: {} episodes, {} failed (N / P: next / previous failure)",
                    dir.display(),
                    b.report.rows.len(),
                    b.failed()
                ));
                self.report = Some(b);
            }
            Err(e) => self.error(e.to_string()),
        }
    }

    /// The report's episodes listed now, in order: what the panel shows.
    pub fn report_rows(&self) -> Vec<usize> {
        self.report
            .as_ref()
            .map_or_else(Vec::new, |b| b.shown().to_vec())
    }

    /// Opens the report's episode `i` (an index into its rows): its checkpoint (loaded if it is
    /// not the one acting), level, seed and sampling, at the step where it was lost; a Python
    /// policy's episode replayed read-only from the actions its report recorded.
    pub fn open_report_episode(&mut self, i: usize) {
        let Some(b) = self.report.as_mut() else {
            return;
        };
        b.selected = Some(i);
        if b.is_python(i) {
            match b.recorded(i) {
                Ok(rec) => self.open_recorded(rec),
                Err(e) => self.error(e.to_string()),
            }
            return;
        }
        match b.episode(i) {
            Ok(request) => self.open(request),
            Err(e) => self.error(e.to_string()),
        }
    }

    /// Shows a Python policy's episode read-only: replayed from the actions its report
    /// recorded, off the UI thread, at the step it opens at, the compared checkpoint beside it
    /// in compare mode. The policy is never run, nor its name loaded as a checkpoint; the
    /// controls take the episode's level, seed and sampling, the checkpoint field keeps what
    /// it held.
    fn open_recorded(&mut self, rec: RecordedEpisode) {
        self.info(rec.line());
        self.request.level = rec.level;
        self.request.seed = rec.seed;
        self.request.mode = rec.mode;
        self.request.mission = None;
        self.mission_text.clear();
        self.pending_step = Some(rec.step);
        // An episode still running is replaced, as a new one replaces it.
        self.jobs.retain(|j| !j.episode);
        self.streaming = false;
        let compare = if self.compare {
            self.compare_agent.clone()
        } else {
            None
        };
        self.jobs.push(start_replay(rec, compare, self.alpha));
    }

    /// A click on the report's episode `i`: it opens, and the list folds away
    /// ([`Browser::pick`]).
    pub fn pick_report_episode(&mut self, i: usize) {
        if let Some(b) = self.report.as_mut() {
            b.pick(i);
        }
        self.open_report_episode(i);
    }

    /// Goes to the next (or previous) failure listed and opens it.
    pub fn step_report_failure(&mut self, forward: bool) {
        let Some(b) = self.report.as_mut() else {
            return;
        };
        match b.step_failure(forward) {
            Some(i) => self.open_report_episode(i),
            None => self.info("no failure among the episodes listed"),
        }
    }

    /// The report's "compare with `checkpoint`": compare mode on, `checkpoint` loaded off the
    /// UI thread, then the selected episode (or the one asked for) run beside it.
    pub fn compare_report_with(&mut self, checkpoint: String) {
        self.compare_text = checkpoint;
        self.compare = true;
        let selected = self.report.as_ref().and_then(|b| b.selected);
        let compare = Some(self.compare_text.trim().to_owned());
        self.jobs
            .push(start_load(None, compare, AfterLoad::Compare(selected)));
    }
}
