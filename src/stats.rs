//! Mean ± std, the one summary every table, report and figure shows: at the bottom of the
//! crate, so that the table writer and the metrics both stand on it.

use serde::{Deserialize, Serialize};

/// Mean and population standard deviation (numpy's default, ddof = 0); the default is
/// nothing measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeanStd {
    /// Mean (null in JSON when nothing was measured).
    pub mean: Option<f64>,
    /// Standard deviation.
    pub std: Option<f64>,
}

impl MeanStd {
    /// Over the finite values of `xs`; `None`s when there are none.
    pub fn of(xs: &[f64]) -> Self {
        let v: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return Self {
                mean: None,
                std: None,
            };
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
        Self {
            mean: Some(mean),
            std: Some(var.sqrt()),
        }
    }
}

impl MeanStd {
    /// As a table over evaluation seeds shows it: `mean ± std` where `spread` (several
    /// seeds), the mean alone where not (one seed: its std is 0 by definition, not a measured
    /// spread), `–` when nothing was measured. [`Display`](std::fmt::Display) always shows the
    /// std (the exploration's spreads are over episodes, measured even for one seed).
    pub fn shown(&self, spread: bool) -> String {
        match self.mean {
            Some(m) if !spread => format!("{m:.3}"),
            _ => self.to_string(),
        }
    }
}

impl std::fmt::Display for MeanStd {
    /// `mean ± std` with three decimals, or `–` when nothing was measured.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.mean, self.std) {
            (Some(m), Some(s)) => write!(f, "{m:.3} ± {s:.3}"),
            _ => f.write_str("–"),
        }
    }
}
