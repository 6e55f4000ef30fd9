//! Errors of the policy: tensors, checkpoints, missions.

use std::path::PathBuf;

use thiserror::Error;

/// Everything that can go wrong in `policy`.
#[derive(Debug, Error)]
pub enum PolicyError {
    /// A tensor operation failed (a shape bug, or out of memory).
    #[error("tensor operation failed: {0}")]
    Tensor(#[from] candle_core::Error),
    /// A checkpoint file could not be read or written.
    #[error("{path}: {reason}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A checkpoint whose content is wrong; names the file and the field or tensor.
    #[error("checkpoint {path}: {field}: {reason}")]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// The field or tensor name.
        field: String,
        /// Why.
        reason: String,
    },
    /// A mission the checkpoint cannot read (unknown word, too long).
    #[error(transparent)]
    Env(#[from] crate::env::EnvError),
    /// Inputs that do not fit together (batch sizes, sequence lengths).
    #[error("invalid input: {0}")]
    Input(String),
}
