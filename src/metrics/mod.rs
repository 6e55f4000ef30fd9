//! Metrics and reports: the paper's grounding accuracies, evaluation sweeps, figures.

mod around;
pub mod assemble;
pub mod bands;
pub mod error;
pub mod exploration;
pub mod failure;
pub mod faithfulness;
pub mod figures;
pub mod grounding;
pub mod report;
pub mod sweep;
pub mod tracking;
pub mod words;

pub use error::MetricsError;
