//! One episode asked for by name: the checkpoint that acts, the level and seed it acts on, how
//! it picks its actions, the step to show first and a mission in place of the level's. The
//! debugger opens episodes in these terms, whether they come from its command line (`view`),
//! from a report (`view --report`) or from its own top bar.

use super::{ActionMode, EpisodeSpec};
use crate::env::level::LevelConfig;

/// An episode to open: which checkpoint, where, how, and at which step.
#[derive(Clone, Debug, PartialEq)]
pub struct EpisodeRequest {
    /// The checkpoint that acts, as the user named it (`bundled:attention`, a path, a
    /// `.onnx` file, `bot`).
    pub checkpoint: String,
    /// The level, in its done mode.
    pub level: LevelConfig,
    /// The level seed.
    pub seed: u64,
    /// Greedy or sampled actions.
    pub mode: ActionMode,
    /// The step shown first (the last one there is, when the episode ends before it).
    pub step: usize,
    /// A mission in place of the generated one (its words in the checkpoint's vocabulary,
    /// naming an object of the level).
    pub mission: Option<String>,
}

impl EpisodeRequest {
    /// `checkpoint` on `level` at `seed`: greedy, from step 0, with the level's own mission.
    pub fn new(checkpoint: impl Into<String>, level: LevelConfig, seed: u64) -> Self {
        Self {
            checkpoint: checkpoint.into(),
            level,
            seed,
            mode: ActionMode::Greedy,
            step: 0,
            mission: None,
        }
    }

    /// What to run, for [`super::run_from`] and its kin (the checkpoint and step aside).
    pub fn spec(&self) -> EpisodeSpec {
        EpisodeSpec {
            level: self.level,
            seed: self.seed,
            mission: self.mission.clone(),
            mode: self.mode,
        }
    }

    /// Whether the actions are sampled.
    pub fn sampled(&self) -> bool {
        self.mode == ActionMode::Sampled
    }
}
