//! What can go wrong with a run, and what a run has to say that is not an error.
//!
//! The run names its settings by their own names ([`RunError::Invalid`]'s `field`, a
//! [`super::Difference`]'s), never by a front end's flag or keyword: `train` maps them to its
//! flags (`--hidden`), the Python `train` to its keyword arguments (`hidden=`).

use std::path::PathBuf;

use crate::metrics::MetricsError;
use crate::policy::PolicyError;

/// Everything that can go wrong in [`crate::run`].
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Another process trains in the directory: it holds the run's lock.
    #[error(
        "{dir}: another training (pid {pid}) is writing this run directory; wait for it to end or choose another run directory"
    )]
    Held {
        /// The run directory.
        dir: PathBuf,
        /// The holder's pid, as its lock file records it.
        pid: String,
    },
    /// A new run refused because its directory already holds one (a caller that can resume
    /// names how).
    #[error("{} already holds a run; resume it or choose another run directory", .0.display())]
    Occupied(PathBuf),
    /// A resume refused because the directory holds no checkpoint (a run stopped before its
    /// first save): a caller names how to start it anew.
    #[error(
        "{} holds no checkpoint to resume (a run stopped before its first save); start it again as a new run",
        .0.display()
    )]
    NothingToResume(PathBuf),
    /// A setting of the run that cannot be trained, named by the run's name for it: a
    /// [`crate::policy::ppo::PpoConfig`] or [`crate::policy::ModelConfig`] field, or `variant`,
    /// `hidden`, `seed`, `levels`, `init`, `imitate`, `eval_interval`, `eval_episodes`,
    /// `save_interval`; `model` and `ppo` for the network's and PPO's own checks (their
    /// reason names the setting).
    #[error("{field}: {reason}")]
    Invalid {
        /// The setting.
        field: &'static str,
        /// Why.
        reason: String,
    },
    /// A warm start from the bot: a planner, with no network weights to start from.
    #[error(
        "the bot is a planner with no network weights to start from; to learn from it, imitate it"
    )]
    BotParent,
    /// A resumed run's log that does not match its checkpoint (missing, not a log, a row
    /// missing or garbled): `what` names the file and the line. The way out is to restore the
    /// log, or to start a new run from the run's weights (a warm start).
    #[error("{what}; restore it, or start a new run from this one's weights")]
    BadLog {
        /// The log.
        path: PathBuf,
        /// What is wrong, the file and line named.
        what: String,
    },
    /// A saved generation whose parts do not load or do not agree.
    #[error("{path}: {reason}")]
    Damaged {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A file or directory of the run that could not be made, read or written.
    #[error("{what}: {error}")]
    Io {
        /// What was being done, the path named.
        what: String,
        /// The system's error (not a `source`: the message shows it once).
        error: std::io::Error,
    },
    /// The network, a checkpoint or training failed (a diverged update included).
    #[error(transparent)]
    Policy(Box<PolicyError>),
    /// The tracked evaluation failed.
    #[error(transparent)]
    Metrics(Box<MetricsError>),
}

impl From<PolicyError> for RunError {
    fn from(e: PolicyError) -> Self {
        Self::Policy(Box::new(e))
    }
}

impl From<MetricsError> for RunError {
    fn from(e: MetricsError) -> Self {
        Self::Metrics(Box::new(e))
    }
}

impl RunError {
    /// An [`RunError::Io`] error while doing `what`.
    pub(crate) fn io(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> Self {
        let what = what.into();
        move |error| Self::Io { what, error }
    }

    /// An [`RunError::Invalid`] setting.
    pub(crate) fn invalid(field: &'static str, reason: impl std::fmt::Display) -> Self {
        Self::Invalid {
            field,
            reason: reason.to_string(),
        }
    }
}

/// What a run has to say besides its progress — nothing fatal: the front end shows it (the
/// run itself prints nothing).
#[derive(Debug, Clone)]
pub enum Notice {
    /// The learning curve could not be drawn (the checkpoint is saved all the same).
    Curve {
        /// The figure.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A resume goes on from an older generation: a newer one does not load.
    Skipped {
        /// The generation resumed from.
        from: PathBuf,
        /// Why the newer one does not load.
        reason: String,
    },
}

impl std::fmt::Display for Notice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Curve { path, reason } => write!(f, "{}: {reason}", path.display()),
            Self::Skipped { from, reason } => write!(
                f,
                "resuming from {} (a newer checkpoint does not load: {reason})",
                from.display()
            ),
        }
    }
}
