//! A run as data: what a [`RunSpec`] is made of before anything is loaded, serializable, so
//! that a study stores it (and hashes it) once at plan time and a later process starts, or
//! resumes, the run from it alone.

use serde::{Deserialize, Serialize};

use super::{Difference, RunInfo, RunSpec, Start, Tracking, model_options};
use crate::policy::ModelConfig;
use crate::policy::ppo::{LevelMix, PpoConfig, TeacherSpec};

/// A run as data: a new run's network, levels, PPO settings, seed, frames and tracking, or a
/// warm start's parent ([`WarmStart`]), which is read only when the run starts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunRecipe {
    /// The network a new run draws (a warm start's is its parent's: its variant and the
    /// settings [`WarmStart::fixed`] names are checked against the parent's, and its model
    /// options that grow a network are added to the parent's).
    pub model: ModelConfig,
    /// The levels trained on.
    pub levels: LevelMix,
    /// The PPO (or imitation) settings.
    pub ppo: PpoConfig,
    /// The seed of the weights and of the run's streams.
    pub seed: u64,
    /// Train until this many frames in total.
    pub frames: u64,
    /// The tracked evaluation and the checkpoint interval.
    pub tracking: Tracking,
    /// Where the run starts from trained weights: the parent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub init: Option<WarmStart>,
    /// `--teacher`: imitation's teachers, loaded when the run starts (file names from the
    /// directory the run's steps run in).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub teachers: Vec<TeacherSpec>,
}

/// A warm start's parent, as a recipe names it: loaded and checked when the run starts.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarmStart {
    /// A checkpoint, a run directory or `bundled:NAME`.
    pub parent: String,
    /// The network settings the recipe gives itself, by the run's names (`hidden`, a model
    /// option such as `conv_kernel`): each must be the parent's; the others are the parent's.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fixed: Vec<String>,
}

impl RunRecipe {
    /// The settings of the run in a directory (`info`, what it was started with) that differ
    /// from this recipe's: what a resume of the recipe refuses, since the directory then holds
    /// another run than the one planned. A warm start's network is its parent's, checked when
    /// it started, so of the network only the settings the recipe gave itself count; and a
    /// word temperature that the recipe anneals is the checkpoint's own by then.
    pub fn resume_differences(&self, info: &RunInfo) -> Vec<Difference> {
        let spec = RunSpec {
            start: self.new_start(),
            frames: self.frames,
            tracking: self.tracking,
            teachers: Vec::new(),
        };
        let network: Vec<&str> = std::iter::once("hidden")
            .chain(model_options(&self.model).map(|(field, _)| field))
            .collect();
        info.differences(&spec)
            .into_iter()
            .filter(|d| {
                let parents = self.init.as_ref().is_some_and(|w| {
                    network.contains(&d.field) && !w.fixed.iter().any(|f| f == d.field)
                });
                let annealed =
                    d.field == "word_temperature" && self.ppo.temperature_anneal.is_some();
                !parents && !annealed
            })
            .collect()
    }

    /// The start of a new run of this recipe's network.
    fn new_start(&self) -> Start {
        Start::New {
            model: self.model,
            levels: self.levels.clone(),
            ppo: self.ppo,
            seed: self.seed,
        }
    }
}
