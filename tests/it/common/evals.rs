//! One evaluation of bundled checkpoints on validation seeds, read back by checkpoint, level
//! and word: what the tests of the grounded agents compare.

use std::collections::BTreeMap;

use super::{csv_rows, gs, stderr};

type Rows = Vec<BTreeMap<String, String>>;

/// The `accuracy.csv` and `performance.csv` rows of one `eval`.
pub struct Eval {
    accuracy: Rows,
    performance: Rows,
}

impl Eval {
    /// Evaluates `checkpoints` on `levels` (comma-separated ids) over 20 episodes of the
    /// validation seeds (level seeds from 1,400,000), the seeds the studies chose on.
    pub fn validation(checkpoints: &[&str], levels: &str) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("report");
        let mut args = vec!["eval"];
        for c in checkpoints {
            args.extend(["--checkpoint", c]);
        }
        let out_arg = out.to_str().unwrap();
        args.extend([
            "--levels",
            levels,
            "--first-seed",
            "1400",
            "--seeds",
            "1",
            "--episodes",
            "20",
            "--out",
            out_arg,
        ]);
        let o = gs(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        Self {
            accuracy: csv_rows(&out.join("accuracy.csv")),
            performance: csv_rows(&out.join("performance.csv")),
        }
    }

    /// `column` (e.g. `acc_mean`, `pointing_mean`) of `word`'s accuracy row for `checkpoint`
    /// on `level`.
    pub fn accuracy(&self, checkpoint: &str, level: &str, word: &str, column: &str) -> f64 {
        let row = self
            .accuracy
            .iter()
            .find(|r| r["checkpoint"] == checkpoint && r["level"] == level && r["word"] == word)
            .unwrap_or_else(|| panic!("no {word} row for {checkpoint} on {level}"));
        row[column].parse().unwrap()
    }

    /// Mean success of `checkpoint` on `level`.
    pub fn success(&self, checkpoint: &str, level: &str) -> f64 {
        let row = self
            .performance
            .iter()
            .find(|r| r["checkpoint"] == checkpoint && r["level"] == level)
            .unwrap_or_else(|| panic!("no performance row for {checkpoint} on {level}"));
        row["success_mean"].parse().unwrap()
    }
}
