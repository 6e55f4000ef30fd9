//! Errors of evaluation and reports.

use std::path::PathBuf;

use thiserror::Error;

/// Everything that can go wrong in `metrics`.
#[derive(Debug, Error)]
pub enum MetricsError {
    /// A file could not be read or written.
    #[error("{path}: {reason}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A file whose content is wrong.
    #[error("{path}: {field}: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// The field, column or line.
        field: String,
        /// Why.
        reason: String,
    },
    /// Arguments that cannot be evaluated (empty sweep, α outside [0, 1], ...).
    #[error("{0}")]
    Invalid(String),
    /// Running a checkpoint failed.
    #[error(transparent)]
    Policy(#[from] crate::policy::PolicyError),
}
