//! Metrics and reports: the paper's grounding accuracies, evaluation sweeps, figures.

pub mod error;
pub mod figures;

pub use error::MetricsError;
