//! A run's steps as data — its training ([`crate::run::RunRecipe`]), the evaluation after it
//! ([`EvalSpec`]) and optionally a faithfulness run ([`FaithfulnessSpec`]) — parsed once when
//! the study is planned, and how an attempt at the run ended ([`ExecOutcome`], and the files
//! [`Done`] and [`Failed`] a run keeps).

use serde::{Deserialize, Serialize};

use crate::run::RunRecipe;

/// One step of a run, in the order they run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Step {
    /// The training, resumed where it stopped.
    Train,
    /// The evaluation of the trained run.
    Eval,
    /// The faithfulness run, where the spec asks for one.
    Faithfulness,
}

impl Step {
    /// The step's name, which is its command's.
    pub fn name(self) -> &'static str {
        match self {
            Self::Train => "train",
            Self::Eval => "eval",
            Self::Faithfulness => "faithfulness",
        }
    }
}

impl std::fmt::Display for Step {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// An evaluation sweep: the paper's rooms (sizes × object counts) or registered levels, the
/// evaluation seeds, episodes per seed and how actions are chosen.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// Room sizes (the paper's level).
    pub sizes: Vec<usize>,
    /// Object counts (the paper's level).
    pub objects: Vec<usize>,
    /// Evaluation seeds per cell.
    pub seeds: u64,
    /// The first evaluation seed.
    pub first_seed: u64,
    /// Episodes per seed.
    pub episodes: u64,
    /// Sampled actions instead of the most probable.
    pub sample: bool,
    /// Registered level ids swept instead of the paper's rooms.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub levels: Vec<String>,
    /// The done-action mode on every level (`true`), BabyAI's registered mode (`false`), or
    /// each level's own (absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub done: Option<bool>,
}

/// The evaluation after a run's training, of the run's checkpoint into `runs/NAME/eval/`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalSpec {
    /// What it sweeps.
    pub sweep: Sweep,
    /// The grounding accuracies' threshold factor α.
    pub alpha: f64,
    /// The occlusion saliency in place of `M` for a model without maps.
    pub saliency: bool,
    /// Worst episodes listed of each kind.
    pub top_k: usize,
    /// The lowest mean success of a cell that passes the evaluation's check.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_success: Option<f64>,
    /// The lowest mean object-word `acc_ng` of an attention cell that passes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_acc_ng: Option<f64>,
    /// Listed failures recorded as Rerun recordings too.
    pub export_failures: bool,
    /// report.html beside report.md, with a page per listed episode (absent: no).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub html: bool,
    /// Worker threads (absent: one per core).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jobs: Option<usize>,
}

/// The parts of a faithfulness run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaithParts {
    /// Per step: occlusion, deletion/insertion, one-step interventions, localisation.
    pub steps: bool,
    /// Whole episodes with an intervention at every step.
    pub closed_loop: bool,
    /// Counterfactual worlds edited at the start.
    pub counterfactuals: bool,
}

/// A faithfulness run after the evaluation, of the run's checkpoint into
/// `runs/NAME/faithfulness/`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaithfulnessSpec {
    /// What it sweeps.
    pub sweep: Sweep,
    /// The parts it computes.
    pub parts: FaithParts,
    /// Worker threads (absent: one per core).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jobs: Option<usize>,
}

/// A run's steps, as a plan makes them.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSteps {
    /// The training.
    pub train: RunRecipe,
    /// The evaluation.
    pub eval: EvalSpec,
    /// The faithfulness run, where the spec asks for one.
    pub faithfulness: Option<FaithfulnessSpec>,
}

/// What `study-done.json` holds: every step of the run ended in order.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Done {
    /// Seconds the attempt that finished it took.
    pub seconds: f64,
}

/// What `study-failed.json` holds: the step that failed, the status its command would have
/// ended with (1: a check failed, 2: an error), and the error.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Failed {
    /// The step.
    pub step: Step,
    /// Its status.
    pub exit: i32,
    /// Its error, one line.
    #[serde(default)]
    pub error: String,
}

/// How one attempt at a run (`study exec`) ended, as it tells whoever started it: a runner
/// reads this, not the exit status alone, so that an exec that ends with 0 and says nothing
/// is a failure named as such, never taken for a run left alone.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "outcome", rename_all = "lowercase")]
pub enum ExecOutcome {
    /// Every step has ended in order (now, or by an earlier attempt): `study-done.json`.
    Done,
    /// Another process holds the run's lock (another exec, or a `train` started by hand): the
    /// run was left alone.
    Elsewhere {
        /// The holder, as its lock file names it.
        holder: String,
    },
    /// A stop (a signal) ended the attempt during `step`, saved: neither done nor failed, the
    /// next attempt resumes it.
    Stopped {
        /// The step it was in.
        step: Step,
    },
    /// A step failed: `study-failed.json`.
    Failed {
        /// The step.
        step: Step,
        /// The status its command would have ended with.
        exit: i32,
        /// Its error, one line.
        error: String,
    },
}
