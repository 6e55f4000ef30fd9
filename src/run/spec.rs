//! What a run does from its start, and the one list of its defaults: `train`'s flags and the
//! Python `train`'s keyword arguments left out take [`RunSpec::default`]'s values.

use serde::{Deserialize, Serialize};

use super::{Parent, RunError, RunInfo};
use crate::env::LevelConfig;
use crate::policy::ppo::{LevelMix, PpoConfig, TeacherSpec, Trainer};
use crate::policy::{ModelConfig, Variant};

/// The checkpoint interval by default (`train --save-interval`), and of a run that recorded
/// none (saved before it was kept).
pub const DEFAULT_SAVE_INTERVAL: u64 = 10;

/// How often, and on how many held-out episodes, a run evaluates itself (`eval_log.csv`), and
/// how often it saves. Kept with the run, so a resume that leaves them out goes on tracking
/// (and saving) the same way.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tracking {
    /// Updates between evaluations (0: never).
    pub eval_interval: u64,
    /// Episodes per evaluation.
    pub eval_episodes: u64,
    /// Updates between checkpoints (absent in runs saved before it was kept: a resume then
    /// takes its caller's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub save_interval: Option<u64>,
}

impl Default for Tracking {
    /// Every 50 updates on 200 episodes; a checkpoint every [`DEFAULT_SAVE_INTERVAL`].
    fn default() -> Self {
        Self {
            eval_interval: 50,
            eval_episodes: 200,
            save_interval: Some(DEFAULT_SAVE_INTERVAL),
        }
    }
}

impl Tracking {
    /// Updates between checkpoints ([`DEFAULT_SAVE_INTERVAL`] for a run that recorded none).
    pub fn save_every(&self) -> u64 {
        self.save_interval.unwrap_or(DEFAULT_SAVE_INTERVAL)
    }

    /// Refuses intervals a run cannot keep, naming the setting.
    pub fn check(&self) -> Result<(), RunError> {
        if self.save_interval == Some(0) {
            return Err(RunError::invalid(
                "save_interval",
                "0: must be at least 1 update",
            ));
        }
        if self.eval_interval > 0 && self.eval_episodes == 0 {
            return Err(RunError::invalid(
                "eval_episodes",
                "0: must be at least 1 (an eval_interval of 0 turns the tracked evaluation off)",
            ));
        }
        Ok(())
    }
}

/// How a run begins.
pub enum Start {
    /// New weights for `model`, drawn from `seed`. A model for a BabyAI level gets rows for
    /// all of BabyAI's words.
    New {
        /// The network.
        model: ModelConfig,
        /// The levels trained on.
        levels: LevelMix,
        /// The PPO (or imitation) settings.
        ppo: PpoConfig,
        /// The seed of the weights and of the run's streams.
        seed: u64,
    },
    /// A parent's weights, with fresh Adam moments and streams; the frame and update counts
    /// continue the parent's, and so do its logs' rows where they sit beside it.
    Init {
        /// The parent ([`Parent::load`]).
        parent: Box<Parent>,
        /// The levels trained on.
        levels: LevelMix,
        /// The PPO settings.
        ppo: PpoConfig,
        /// The seed of the run's streams.
        seed: u64,
    },
    /// The run in the directory, exactly where its checkpoint left it
    /// ([`super::RunDir::load`]).
    Resume {
        /// Its trainer.
        trainer: Box<Trainer>,
        /// What it was started with.
        info: Box<RunInfo>,
    },
}

impl Start {
    /// The network: the new one, the parent's, or the resumed run's.
    pub fn model(&self) -> &ModelConfig {
        match self {
            Self::New { model, .. } => model,
            Self::Init { parent, .. } => &parent.checkpoint.meta.model,
            Self::Resume { info, .. } => &info.model,
        }
    }

    /// The levels trained on.
    pub fn levels(&self) -> &LevelMix {
        match self {
            Self::New { levels, .. } | Self::Init { levels, .. } => levels,
            Self::Resume { info, .. } => &info.levels,
        }
    }

    /// The PPO settings.
    pub fn ppo(&self) -> &PpoConfig {
        match self {
            Self::New { ppo, .. } | Self::Init { ppo, .. } => ppo,
            Self::Resume { info, .. } => &info.ppo,
        }
    }

    /// The run's seed.
    pub fn seed(&self) -> u64 {
        match self {
            Self::New { seed, .. } | Self::Init { seed, .. } => *seed,
            Self::Resume { info, .. } => info.seed,
        }
    }
}

/// What a run does from its start.
pub struct RunSpec {
    /// How it begins.
    pub start: Start,
    /// Train until this many frames in total (a resumed or warm-started run counts its
    /// earlier frames).
    pub frames: u64,
    /// The tracked evaluation and the checkpoint interval.
    pub tracking: Tracking,
    /// `--teacher`: trained policies whose greedy actions label imitation's frames on the
    /// levels they teach (a new or warm-started run; a resumed one keeps its own).
    pub teachers: Vec<TeacherSpec>,
}

impl Default for RunSpec {
    /// The one list of a run's defaults: a new attention model of the paper's sizes (LSTM and
    /// GRU 128) on the paper's level, seed 1, PPO's defaults ([`PpoConfig::default`]), 5M
    /// frames, tracked every 50 updates on 200 episodes, a checkpoint every 10 updates.
    fn default() -> Self {
        Self {
            start: Start::New {
                model: ModelConfig::new(Variant::Attention),
                levels: LevelConfig::default().into(),
                ppo: PpoConfig::default(),
                seed: 1,
            },
            frames: 5_000_000,
            tracking: Tracking::default(),
            teachers: Vec::new(),
        }
    }
}

impl RunSpec {
    /// Refuses what a new or warm-started run cannot train, naming the setting, before any
    /// run directory is touched: the intervals, the network, the PPO settings, the levels,
    /// the settings that need word maps, a parent that lacks a word of the levels' missions
    /// ([`Parent::check_words`]), and imitation on levels the bot labels (almost) nothing of
    /// ([`super::check_labels`]). Returns the levels the bot labels too little of for a
    /// warning (each with its share), where others are labelled.
    pub fn check(&self) -> Result<Vec<String>, RunError> {
        self.tracking.check()?;
        let (model, levels, ppo) = match &self.start {
            Start::New {
                model, levels, ppo, ..
            } => {
                model
                    .validate()
                    .map_err(|e| RunError::invalid("model", e))?;
                (model, levels, ppo)
            }
            Start::Init {
                parent,
                levels,
                ppo,
                ..
            } => {
                parent.check_words(levels)?;
                (&parent.checkpoint.meta.model, levels, ppo)
            }
            Start::Resume { .. } => {
                return Err(RunError::invalid(
                    "start",
                    "a resumed run keeps its own settings: resume it, do not create it",
                ));
            }
        };
        ppo.validate().map_err(|e| RunError::invalid("ppo", e))?;
        for e in levels.entries() {
            e.level
                .validate()
                .map_err(|err| RunError::invalid("levels", err))?;
        }
        if ppo.freeze_attention_at.is_some() && !model.has_attention() {
            return Err(RunError::invalid(
                "freeze_attention_at",
                "a baseline has no word maps to freeze (the attention model has)",
            ));
        }
        if ppo.ground_loss > 0.0 && !model.has_attention() {
            return Err(RunError::invalid(
                "ground_loss",
                "a baseline has no word maps to supervise (the attention model has)",
            ));
        }
        if !self.teachers.is_empty() {
            if !ppo.imitate {
                return Err(RunError::invalid(
                    "teacher",
                    "a teacher labels imitation's frames: it needs imitate",
                ));
            }
            let specs = super::absolute_teachers(&self.teachers)?;
            super::load_teachers(&specs, levels)?;
            let of_entry = crate::policy::ppo::teacher_of(&specs, levels)
                .map_err(|e| RunError::invalid("teacher", e))?;
            // The taught levels are labelled, so a level the bot leaves silent is a warning.
            let mut silent = Vec::new();
            for (e, _) in levels
                .entries()
                .iter()
                .zip(of_entry)
                .filter(|(_, t)| t.is_none())
            {
                match super::check_labels(&LevelMix::from(e.level)) {
                    Ok(some) => silent.extend(some),
                    Err(RunError::Invalid { .. }) => silent.push(e.level.id()),
                    Err(other) => return Err(other),
                }
            }
            return Ok(silent);
        }
        if ppo.imitate {
            return super::check_labels(levels);
        }
        Ok(Vec::new())
    }
}
