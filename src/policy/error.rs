//! Errors of the policy: tensors, checkpoints, missions.

use std::path::PathBuf;

use thiserror::Error;

/// Everything that can go wrong in `policy`.
#[derive(Debug, Error)]
pub enum PolicyError {
    /// A tensor operation failed (a shape bug, or out of memory).
    // Not `#[from]`: that would make candle's error the source too, and a `{:#}` chain would
    // print its text twice.
    #[error("tensor operation failed: {0}")]
    Tensor(candle_core::Error),
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

impl From<candle_core::Error> for PolicyError {
    fn from(e: candle_core::Error) -> Self {
        Self::Tensor(e)
    }
}

#[cfg(test)]
mod tests {
    use super::PolicyError;

    #[test]
    fn a_candle_error_is_printed_once_in_an_error_chain() {
        let e: PolicyError = candle_core::Error::Msg("shape mismatch 7".into()).into();
        let text = format!("{:#}", anyhow::Error::from(e));
        assert_eq!(text.matches("shape mismatch 7").count(), 1, "{text}");
    }
}
