//! Grounding tracked during training (`train --eval-interval`): a fixed held-out set of greedy
//! episodes on the training level (on each level of a `--levels` run, and their mean),
//! evaluated every few updates and appended to `eval_log.csv`, so a recipe can be chosen on
//! data that is neither trained on nor the final test set.

use serde::{Deserialize, Serialize};

use super::error::MetricsError;
use super::grounding::WordKind;
use super::sweep::{evaluate_episodes, grounding, performance};
use crate::env::level::LevelConfig;
use crate::episode::ActionMode;

pub use crate::env::seeds::VALIDATION_SEED_BASE;

/// The `eval_log.csv` header.
pub const EVAL_LOG_HEADER: &str = "update,frames,episodes,greedy_success,mean_reward,mean_length,object_acc,object_acc_ng,color_acc,color_acc_ng,combined_acc,combined_acc_ng,eval_secs,level";

/// The header `eval_log.csv` had before it named the level (such logs are read with an empty
/// `level`: the run's level).
pub const EVAL_LOG_HEADER_V1: &str = "update,frames,episodes,greedy_success,mean_reward,mean_length,object_acc,object_acc_ng,color_acc,color_acc_ng,combined_acc,combined_acc_ng,eval_secs";

/// The `level` of a `--levels` run's row that averages its levels' rows.
pub const MEAN_OF_LEVELS: &str = "mean of levels";

/// One row of `eval_log.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackedEval {
    /// Updates done when it was measured.
    pub update: u64,
    /// Frames trained on.
    pub frames: u64,
    /// Episodes evaluated.
    pub episodes: u64,
    /// Greedy success rate.
    pub greedy_success: f64,
    /// Mean reward.
    pub mean_reward: f64,
    /// Mean episode length.
    pub mean_length: f64,
    /// Object-word `acc` and `acc_ng` (NaN for a baseline or when never evaluated).
    pub object: (f64, f64),
    /// Colour-word `acc` and `acc_ng`.
    pub color: (f64, f64),
    /// `M` on the targets, `acc` and `acc_ng`.
    pub combined: (f64, f64),
    /// Wall time of the evaluation.
    pub eval_secs: f64,
    /// The level evaluated (as `LevelConfig` displays it), or [`MEAN_OF_LEVELS`].
    pub level: String,
}

impl TrackedEval {
    /// The row's fields ([`EVAL_LOG_HEADER`]'s columns); NaNs are written as empty fields.
    pub fn record(&self) -> crate::table::Record {
        let f = |x: f64| {
            if x.is_finite() {
                format!("{x:.4}")
            } else {
                String::new()
            }
        };
        crate::table::Record::new()
            .field(self.update)
            .field(self.frames)
            .field(self.episodes)
            .field(f(self.greedy_success))
            .field(f(self.mean_reward))
            .field(f(self.mean_length))
            .field(f(self.object.0))
            .field(f(self.object.1))
            .field(f(self.color.0))
            .field(f(self.color.1))
            .field(f(self.combined.0))
            .field(f(self.combined.1))
            .field(format!("{:.2}", self.eval_secs))
            .field(&self.level)
    }

    /// The unweighted mean of several levels' rows (each field over the levels where it is
    /// defined; episodes and wall time summed), labelled [`MEAN_OF_LEVELS`].
    pub fn mean_of(rows: &[Self]) -> Option<Self> {
        let first = rows.first()?;
        let mean = |f: &dyn Fn(&Self) -> f64| {
            let xs: Vec<f64> = rows.iter().map(f).filter(|x| x.is_finite()).collect();
            if xs.is_empty() {
                f64::NAN
            } else {
                xs.iter().sum::<f64>() / xs.len() as f64
            }
        };
        Some(Self {
            update: first.update,
            frames: first.frames,
            episodes: rows.iter().map(|r| r.episodes).sum(),
            greedy_success: mean(&|r| r.greedy_success),
            mean_reward: mean(&|r| r.mean_reward),
            mean_length: mean(&|r| r.mean_length),
            object: (mean(&|r| r.object.0), mean(&|r| r.object.1)),
            color: (mean(&|r| r.color.0), mean(&|r| r.color.1)),
            combined: (mean(&|r| r.combined.0), mean(&|r| r.combined.1)),
            eval_secs: rows.iter().map(|r| r.eval_secs).sum(),
            level: MEAN_OF_LEVELS.to_owned(),
        })
    }
}

/// Evaluates `net` greedily on the first `episodes` held-out levels of `level`.
pub fn track<P: crate::policy::Acting + ?Sized>(
    net: &P,
    level: &LevelConfig,
    episodes: u64,
    update: u64,
    frames: u64,
) -> Result<TrackedEval, MetricsError> {
    let start = std::time::Instant::now();
    let plan: Vec<(u64, u64)> = (0..episodes)
        .map(|e| (0, VALIDATION_SEED_BASE + e))
        .collect();
    let eps = evaluate_episodes(net, level, &plan, 0.5, ActionMode::Greedy, &mut |_| {})?;
    let perf = performance(&eps);
    let nan = f64::NAN;
    let acc = |kind| {
        let g = grounding(&eps, kind);
        (g.acc.mean.unwrap_or(nan), g.acc_ng.mean.unwrap_or(nan))
    };
    Ok(TrackedEval {
        update,
        frames,
        episodes,
        greedy_success: perf.success.mean.unwrap_or(nan),
        mean_reward: perf.reward.mean.unwrap_or(nan),
        mean_length: perf.length.mean.unwrap_or(nan),
        object: acc(WordKind::Object),
        color: acc(WordKind::Color),
        combined: acc(WordKind::Combined),
        eval_secs: start.elapsed().as_secs_f64(),
        level: level.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_match_the_header_and_leave_nan_empty() {
        let row = TrackedEval {
            update: 3,
            frames: 6144,
            episodes: 10,
            greedy_success: 0.5,
            mean_reward: 0.25,
            mean_length: 30.0,
            object: (0.1, 0.2),
            color: (f64::NAN, f64::NAN),
            combined: (0.3, 0.4),
            eval_secs: 1.5,
            level: "BabyAI-GoToLocal-v0".into(),
        };
        let mut other = row.clone();
        other.greedy_success = f64::NAN;
        other.object = (0.3, 0.4);
        let mean = TrackedEval::mean_of(&[row.clone(), other]).unwrap();
        assert_eq!(mean.greedy_success, 0.5);
        assert!((mean.object.0 - 0.2).abs() < 1e-12);
        assert_eq!(mean.episodes, 20);
        assert_eq!(mean.level, MEAN_OF_LEVELS);
        let row = crate::table::line(&row.record());
        assert_eq!(row.split(',').count(), EVAL_LOG_HEADER.split(',').count());
        assert!(row.ends_with("1.50,BabyAI-GoToLocal-v0\n"), "{row}");
        assert!(row.contains(",0.2000,,,0.3000,"), "{row}");
    }
}
