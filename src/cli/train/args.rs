//! `train`'s flags, and the settings they give a new run.

use std::path::PathBuf;

use clap::Args;
use groundscope::policy::WordTemperature;
use groundscope::policy::ppo::{LevelMix, PpoConfig, TemperatureAnneal};
use groundscope::run::RunSpec;

use crate::cli::env_cmd::LevelArgs;
use crate::cli::model_options::ModelOptions;

/// `groundscope train`. Every default is a run's ([`RunSpec::default`]).
#[derive(Debug, Args)]
#[expect(
    clippy::struct_excessive_bools,
    reason = "command-line switches, each its own flag"
)]
#[command(
    after_long_help = "EXAMPLES:\n  groundscope train --model attention --out runs/att --frames 5000000\n  groundscope train --model attention --out runs/att --frames 8000000 --resume\n  groundscope train --model attention --out runs/att2 --init runs/att/model --entropy-coef 0.001 --frames 9000000\n  groundscope train --imitate --level BabyAI-PutNextLocal-v0 --out runs/il --frames 2000000\n  groundscope train --imitate --levels BabyAI-GoToLocal-v0,BabyAI-PickupLoc-v0:2 --out runs/mix --eval-episodes 100"
)]
pub struct TrainArgs {
    /// attention or baseline.
    #[arg(long, value_name = "MODEL", default_value_t = default_model())]
    pub model: String,
    /// Run directory: model.{safetensors,json}, log.csv, resume state.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Train until this many frames in total (a resumed run counts its earlier frames).
    #[arg(long, default_value_t = RunSpec::default().frames, allow_negative_numbers = true)]
    pub frames: u64,
    /// Seed of the initial weights and of the sampling / shuffling streams.
    #[arg(long, default_value_t = RunSpec::default().start.seed(), allow_negative_numbers = true)]
    pub seed: u64,
    /// Continue the run in --out exactly where it stopped (weights, Adam, RNGs, environments).
    #[arg(long)]
    pub resume: bool,
    /// Start a new run from this checkpoint's weights (NAME, a run directory or
    /// bundled:NAME) with the hyper-parameters given here: fresh Adam and RNG streams, frame
    /// and update counts continued from the checkpoint, network sizes taken from it.
    #[arg(long, value_name = "NAME", conflicts_with = "resume")]
    pub init: Option<String>,
    /// Save a checkpoint every this many updates.
    #[arg(long, default_value_t = RunSpec::default().tracking.save_every(), allow_negative_numbers = true)]
    pub save_interval: u64,
    #[command(flatten, next_help_heading = "Level")]
    pub level: LevelArgs,
    /// Train on several registered levels at once: ids separated by commas, each optionally
    /// weighted `ID:WEIGHT` (default 1), e.g. BabyAI-GoToLocal-v0:2,BabyAI-PickupLoc-v0. Each
    /// episode's level is drawn by its seed; `--done` applies to all; the tracked evaluation
    /// runs on every level and writes their mean too.
    #[arg(
        help_heading = "Level",
        long,
        value_name = "IDS",
        conflicts_with_all = ["level", "size", "objects", "tasks", "always_color", "no_done"]
    )]
    pub levels: Option<String>,
    /// Environments stepped together.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().procs, allow_negative_numbers = true)]
    pub procs: usize,
    /// Frames per environment per update.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().frames_per_proc, allow_negative_numbers = true)]
    pub frames_per_proc: usize,
    /// PPO epochs per update.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().epochs, allow_negative_numbers = true)]
    pub epochs: usize,
    /// Frames per minibatch.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().batch_size, allow_negative_numbers = true)]
    pub batch_size: usize,
    /// BPTT chunk length.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().recurrence, allow_negative_numbers = true)]
    pub recurrence: usize,
    /// Adam learning rate.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().lr, allow_negative_numbers = true)]
    pub lr: f64,
    /// Adam epsilon.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().adam_eps, allow_negative_numbers = true)]
    pub adam_eps: f64,
    /// Discount factor.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().discount, allow_negative_numbers = true)]
    pub discount: f64,
    /// GAE lambda.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().gae_lambda, allow_negative_numbers = true)]
    pub gae_lambda: f64,
    /// Entropy bonus coefficient.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().entropy_coef, allow_negative_numbers = true)]
    pub entropy_coef: f64,
    /// Value loss coefficient.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().value_loss_coef, allow_negative_numbers = true)]
    pub value_loss_coef: f64,
    /// Gradient-norm clip.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().max_grad_norm, allow_negative_numbers = true)]
    pub max_grad_norm: f64,
    /// PPO clip epsilon.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().clip_eps, allow_negative_numbers = true)]
    pub clip_eps: f64,
    /// Threads for the whole update: the rollout's environments and forward passes, each
    /// minibatch's forward and backward pass and the optimizer step are split over them
    /// (results depend on the count, never on timing). `--update-threads` is the old name.
    #[arg(help_heading = "PPO", long, alias = "update-threads", default_value_t = ppo_default().threads, allow_negative_numbers = true)]
    pub threads: usize,
    /// Multiply rewards by this for GAE and the value loss (BabyAI: 20); logs stay unscaled.
    #[arg(help_heading = "PPO", long, default_value_t = ppo_default().reward_scale, allow_negative_numbers = true)]
    pub reward_scale: f64,
    /// Normalise each rollout's advantages to mean 0, standard deviation 1.
    #[arg(help_heading = "PPO", long)]
    pub normalize_advantages: bool,
    /// Imitation learning: behavioural cloning of minigrid's BabyAI bot on demonstrations made
    /// on the fly (the bot's actions are taken; the policy loss is their cross-entropy), with
    /// the entropy bonus and value loss as PPO's; the rest of the run (rollouts, recurrence,
    /// logs, checkpoints, `--resume`) as a PPO run's. Then PPO from its weights: `--init RUN`.
    #[arg(help_heading = "Imitation", long)]
    pub imitate: bool,
    /// With --imitate: the share of steps (0 to 1) that take the policy's own sampled action
    /// while the bot's advice stays the label (DAgger's mixture: the bot replans from where
    /// the agent went, so the policy learns to recover from its mistakes); 0 is pure cloning.
    #[arg(
        help_heading = "Imitation",
        long,
        value_name = "P",
        default_value_t = ppo_default().imitate_policy_share,
        allow_negative_numbers = true
    )]
    pub imitate_policy_share: f64,
    /// With --imitate: a trained policy whose greedy actions label (and take) the steps of
    /// level ID, in place of the bot's; without `ID=`, of every level no other --teacher
    /// names (policy distillation). Repeatable; a level no teacher names keeps the bot.
    /// A checkpoint, a run directory or `bundled:NAME`; recorded in the run, so a resume
    /// loads the same teachers.
    #[arg(help_heading = "Imitation", long, value_name = "[ID=]CHECKPOINT")]
    pub teacher: Vec<String>,
    /// Supervise the word maps with weight λ (0 to 100; 0, the default, leaves them
    /// unsupervised as the paper does): on each frame, −ln of each scored word's map mass on
    /// the objects it names in view, and of M's mass on the objects the clauses waited on
    /// matched, added to the loss times λ. Attention models only; named in the checkpoint.
    #[arg(
        help_heading = "Maps",
        long,
        value_name = "LAMBDA",
        default_value_t = ppo_default().ground_loss,
        allow_negative_numbers = true
    )]
    pub ground_loss: f64,
    /// Anneal the word temperature from --word-temperature (the model's, with --init) to 1,
    /// the paper's, linearly between START and END frames: START:END, e.g. 6000000:9000000.
    #[arg(
        help_heading = "Maps",
        long,
        value_name = "START:END",
        allow_hyphen_values = true
    )]
    pub word_temperature_anneal: Option<String>,
    /// From this many frames on, stop training the parameters that compute the word maps
    /// (word embeddings, encoder, query and key projections); the LSTM, the mission GRU, actor
    /// and critic keep learning. Attention models only.
    #[arg(
        help_heading = "Maps",
        long,
        value_name = "FRAMES",
        allow_negative_numbers = true
    )]
    pub freeze_attention_at: Option<u64>,
    /// Evaluate greedily on the held-out validation levels every this many updates and append
    /// the result to eval_log.csv (0: never).
    #[arg(
        help_heading = "Tracked evaluation",
        long,
        default_value_t = RunSpec::default().tracking.eval_interval,
        allow_negative_numbers = true
    )]
    pub eval_interval: u64,
    /// Held-out validation episodes per evaluation (level seeds 2^31 + e, never trained on and
    /// not among `eval`'s test seeds).
    #[arg(
        help_heading = "Tracked evaluation",
        long,
        default_value_t = RunSpec::default().tracking.eval_episodes,
        allow_negative_numbers = true
    )]
    pub eval_episodes: u64,
    /// Hidden size of the LSTM and GRU (smaller trains faster; the paper's default is 128).
    #[arg(
        help_heading = "Model",
        long,
        default_value_t = RunSpec::default().start.model().lstm_hidden,
        allow_negative_numbers = true
    )]
    pub hidden: usize,
    #[command(flatten, next_help_heading = "Model")]
    pub model_options: ModelOptions,
    /// Hide the progress bar (log lines only).
    #[arg(help_heading = "Output", long)]
    pub quiet: bool,
}

/// A run's PPO settings by default (the PPO flags' defaults).
fn ppo_default() -> PpoConfig {
    *RunSpec::default().start.ppo()
}

/// A run's model by default (`--model`'s default).
fn default_model() -> String {
    RunSpec::default().start.model().variant.name().to_owned()
}

/// The run's PPO settings from the command line; `from` is the temperature an annealing
/// schedule starts at (the new model's, or the checkpoint's with `--init`).
pub(in crate::cli) fn ppo_config(a: &TrainArgs, from: f32) -> anyhow::Result<PpoConfig> {
    let temperature_anneal = a
        .word_temperature_anneal
        .as_deref()
        .map(|s| TemperatureAnneal::parse(s, from, WordTemperature::PAPER.0))
        .transpose()?;
    Ok(PpoConfig {
        procs: a.procs,
        frames_per_proc: a.frames_per_proc,
        epochs: a.epochs,
        batch_size: a.batch_size,
        recurrence: a.recurrence,
        lr: a.lr,
        adam_eps: a.adam_eps,
        discount: a.discount,
        gae_lambda: a.gae_lambda,
        entropy_coef: a.entropy_coef,
        value_loss_coef: a.value_loss_coef,
        max_grad_norm: a.max_grad_norm,
        clip_eps: a.clip_eps,
        threads: a.threads,
        reward_scale: a.reward_scale,
        normalize_advantages: a.normalize_advantages,
        temperature_anneal,
        freeze_attention_at: a.freeze_attention_at,
        imitate: a.imitate,
        imitate_policy_share: a.imitate_policy_share,
        ground_loss: a.ground_loss,
    })
}

/// The levels a new run trains on: `--levels`, or the one level the level flags describe.
pub(in crate::cli) fn level_mix(a: &TrainArgs) -> anyhow::Result<LevelMix> {
    match &a.levels {
        Some(list) => Ok(LevelMix::parse(list, a.level.done)?),
        None => Ok(a.level.config()?.into()),
    }
}
