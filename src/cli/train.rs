//! `groundscope train`: recurrent PPO with checkpoints, resume, logs and Ctrl-C handling.

mod lock;

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use anyhow::Context as _;
use clap::ArgMatches;
use clap::Args;
use groundscope::metrics::tracking::{EVAL_LOG_HEADER, EVAL_LOG_HEADER_V1, TrackedEval};
use groundscope::policy::checkpoint::write_atomic;
use groundscope::policy::ppo::{LevelMix, PpoConfig, TemperatureAnneal, Trainer, UpdateLog};
use groundscope::policy::{ModelConfig, Net, Params, TrainingState, WordTemperature};

use crate::ExitStatus;
use crate::cli::env_cmd::LevelArgs;
use crate::cli::model_options::ModelOptions;
use crate::cli::policy_cmd::parse_variant;
use crate::cli::train_start::{resume_run, tracking, warm_start};
use groundscope::policy::ppo::run_dir::{self, Tracking};
use lock::{RUN_LOCK, lock_run};

/// `groundscope train`.
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
    #[arg(long, value_name = "MODEL", default_value = "attention")]
    pub model: String,
    /// Run directory: model.{safetensors,json}, log.csv, resume state.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Train until this many frames in total (a resumed run counts its earlier frames).
    #[arg(long, default_value_t = 5_000_000, allow_negative_numbers = true)]
    pub frames: u64,
    /// Seed of the initial weights and of the sampling / shuffling streams.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
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
    #[arg(long, default_value_t = 10, allow_negative_numbers = true)]
    pub save_interval: u64,
    #[command(flatten)]
    pub level: LevelArgs,
    /// Train on several registered levels at once: ids separated by commas, each optionally
    /// weighted `ID:WEIGHT` (default 1), e.g. BabyAI-GoToLocal-v0:2,BabyAI-PickupLoc-v0. Each
    /// episode's level is drawn by its seed; `--done` applies to all; the tracked evaluation
    /// runs on every level and writes their mean too.
    #[arg(
        long,
        value_name = "IDS",
        conflicts_with_all = ["level", "size", "objects", "tasks", "always_color", "no_done"]
    )]
    pub levels: Option<String>,
    /// Environments stepped together.
    #[arg(long, default_value_t = PpoConfig::default().procs, allow_negative_numbers = true)]
    pub procs: usize,
    /// Frames per environment per update.
    #[arg(long, default_value_t = PpoConfig::default().frames_per_proc, allow_negative_numbers = true)]
    pub frames_per_proc: usize,
    /// PPO epochs per update.
    #[arg(long, default_value_t = PpoConfig::default().epochs, allow_negative_numbers = true)]
    pub epochs: usize,
    /// Frames per minibatch.
    #[arg(long, default_value_t = PpoConfig::default().batch_size, allow_negative_numbers = true)]
    pub batch_size: usize,
    /// BPTT chunk length.
    #[arg(long, default_value_t = PpoConfig::default().recurrence, allow_negative_numbers = true)]
    pub recurrence: usize,
    /// Adam learning rate.
    #[arg(long, default_value_t = PpoConfig::default().lr, allow_negative_numbers = true)]
    pub lr: f64,
    /// Adam epsilon.
    #[arg(long, default_value_t = PpoConfig::default().adam_eps, allow_negative_numbers = true)]
    pub adam_eps: f64,
    /// Discount factor.
    #[arg(long, default_value_t = PpoConfig::default().discount, allow_negative_numbers = true)]
    pub discount: f64,
    /// GAE lambda.
    #[arg(long, default_value_t = PpoConfig::default().gae_lambda, allow_negative_numbers = true)]
    pub gae_lambda: f64,
    /// Entropy bonus coefficient.
    #[arg(long, default_value_t = PpoConfig::default().entropy_coef, allow_negative_numbers = true)]
    pub entropy_coef: f64,
    /// Value loss coefficient.
    #[arg(long, default_value_t = PpoConfig::default().value_loss_coef, allow_negative_numbers = true)]
    pub value_loss_coef: f64,
    /// Gradient-norm clip.
    #[arg(long, default_value_t = PpoConfig::default().max_grad_norm, allow_negative_numbers = true)]
    pub max_grad_norm: f64,
    /// PPO clip epsilon.
    #[arg(long, default_value_t = PpoConfig::default().clip_eps, allow_negative_numbers = true)]
    pub clip_eps: f64,
    /// Threads for the whole update: the rollout's environments and forward passes, each
    /// minibatch's forward and backward pass and the optimizer step are split over them
    /// (results depend on the count, never on timing). `--update-threads` is the old name.
    #[arg(long, alias = "update-threads", default_value_t = PpoConfig::default().threads, allow_negative_numbers = true)]
    pub threads: usize,
    /// Multiply rewards by this for GAE and the value loss (BabyAI: 20); logs stay unscaled.
    #[arg(long, default_value_t = PpoConfig::default().reward_scale, allow_negative_numbers = true)]
    pub reward_scale: f64,
    /// Normalise each rollout's advantages to mean 0, standard deviation 1.
    #[arg(long)]
    pub normalize_advantages: bool,
    /// Imitation learning: behavioural cloning of minigrid's BabyAI bot on demonstrations made
    /// on the fly (the bot's actions are taken; the policy loss is their cross-entropy), with
    /// the entropy bonus and value loss as PPO's; the rest of the run (rollouts, recurrence,
    /// logs, checkpoints, `--resume`) as a PPO run's. Then PPO from its weights: `--init RUN`.
    #[arg(long)]
    pub imitate: bool,
    /// With --imitate: the share of steps (0 to 1) that take the policy's own sampled action
    /// while the bot's advice stays the label (DAgger's mixture: the bot replans from where
    /// the agent went, so the policy learns to recover from its mistakes); 0 is pure cloning.
    #[arg(
        long,
        value_name = "P",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub imitate_policy_share: f64,
    /// Supervise the word maps with weight λ (0 to 100; 0, the default, leaves them
    /// unsupervised as the paper does): on each frame, −ln of each scored word's map mass on
    /// the objects it names in view, and of M's mass on the objects the clauses waited on
    /// matched, added to the loss times λ. Attention models only; named in the checkpoint.
    #[arg(
        long,
        value_name = "LAMBDA",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub ground_loss: f64,
    /// Anneal the word temperature from --word-temperature (the model's, with --init) to 1,
    /// the paper's, linearly between START and END frames: START:END, e.g. 6000000:9000000.
    #[arg(long, value_name = "START:END", allow_hyphen_values = true)]
    pub word_temperature_anneal: Option<String>,
    /// From this many frames on, stop training the parameters that compute the word maps
    /// (word embeddings, encoder, query and key projections); the LSTM, the mission GRU, actor
    /// and critic keep learning. Attention models only.
    #[arg(long, value_name = "FRAMES", allow_negative_numbers = true)]
    pub freeze_attention_at: Option<u64>,
    /// Evaluate greedily on the held-out validation levels every this many updates and append
    /// the result to eval_log.csv (0: never).
    #[arg(long, default_value_t = 50, allow_negative_numbers = true)]
    pub eval_interval: u64,
    /// Held-out validation episodes per evaluation (level seeds 2^31 + e, never trained on and
    /// not among `eval`'s test seeds).
    #[arg(long, default_value_t = 200, allow_negative_numbers = true)]
    pub eval_episodes: u64,
    /// Hidden size of the LSTM and GRU (smaller trains faster; the paper's default is 128).
    #[arg(long, default_value_t = 128, allow_negative_numbers = true)]
    pub hidden: usize,
    #[command(flatten)]
    pub model_options: ModelOptions,
    /// Hide the progress bar (log lines only).
    #[arg(long)]
    pub quiet: bool,
}

const LOG_HEADER: &str = "update,frames,fps,episodes,success_rate,mean_reward,mean_length,policy_loss,value_loss,entropy,grad_norm,elapsed_secs";

/// The run's PPO settings from the command line; `from` is the temperature an annealing
/// schedule starts at (the new model's, or the checkpoint's with `--init`).
pub(super) fn ppo_config(a: &TrainArgs, from: f32) -> anyhow::Result<PpoConfig> {
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
pub(super) fn level_mix(a: &TrainArgs) -> anyhow::Result<LevelMix> {
    match &a.levels {
        Some(list) => Ok(LevelMix::parse(list, a.level.done)?),
        None => Ok(a.level.config()?.into()),
    }
}

/// The training state recorded with a checkpoint: `last` is the newest update's log (a run
/// resumed with nothing left to do keeps the metrics `keep` it had).
fn training_state(
    trainer: &Trainer,
    seed: u64,
    last: Option<&UpdateLog>,
    keep: Option<&TrainingState>,
) -> TrainingState {
    let finite = |x: f64| Some(x).filter(|x| x.is_finite());
    TrainingState {
        frames: trainer.state.frames,
        updates: trainer.state.updates,
        success_rate: last.map_or_else(
            || keep.and_then(|k| k.success_rate),
            |l| finite(l.success_rate),
        ),
        mean_reward: last.map_or_else(
            || keep.and_then(|k| k.mean_reward),
            |l| finite(l.mean_reward),
        ),
        seed,
        ground_loss: (trainer.ppo.ground_loss > 0.0)
            .then_some(trainer.ppo.ground_loss)
            .or(trainer.state.parent_ground_loss),
    }
}

/// Saves a generation and redraws the run's learning curve (a figure: its failure is
/// reported, not fatal, since the checkpoint is already safe).
fn save_run(
    trainer: &Trainer,
    dir: &Path,
    training: TrainingState,
    tracking: Tracking,
) -> anyhow::Result<()> {
    run_dir::save(trainer, dir, training, tracking)?;
    let drawn = groundscope::metrics::figures::read_training_log(&dir.join("log.csv"))
        .map_err(anyhow::Error::from)
        .and_then(|points| {
            let curve = groundscope::metrics::figures::Curve {
                label: trainer.model.variant.name().to_owned(),
                points,
            };
            groundscope::metrics::figures::learning_curve(
                &[curve],
                "Mean reward during training",
                &dir.join("curve.png"),
            )
            .map_err(anyhow::Error::from)
        });
    if let Err(e) = drawn {
        eprintln!("groundscope: {}: {e:#}", dir.join("curve.png").display());
    }
    Ok(())
}

/// The rows of the `log.csv` beside checkpoint `name` up to `updates`, so a warm-started
/// run's log and learning curve start at frame 0. Empty when there is no such log.
fn parent_log_rows(name: &str, file: &str, header: &str, updates: u64) -> String {
    if name.starts_with(groundscope::policy::bundled::PREFIX) {
        return String::new();
    }
    // The logs sit beside the checkpoint (inside a run directory given as the name).
    let name = groundscope::policy::checkpoint::checkpoint_name(Path::new(name));
    let dir = name.parent().unwrap_or(Path::new("."));
    log_rows_upto(&dir.join(file), header, updates)
}

/// The rows of training log `path` for updates `1..=updates` (none when it is missing or not
/// a training log). A run killed between checkpoints has logged updates its checkpoint does
/// not hold; `--resume` does them again, so their first rows are dropped.
fn log_rows_upto(path: &Path, header: &str, updates: u64) -> String {
    let Ok(text) = std::fs::read_to_string(path) else {
        return String::new();
    };
    let mut lines = text.lines();
    // An eval_log.csv written before it named the level gains an empty `level` field.
    let pad = match lines.next() {
        Some(h) if h == header => "",
        Some(h) if h == EVAL_LOG_HEADER_V1 && header == EVAL_LOG_HEADER => ",",
        _ => return String::new(),
    };
    let mut rows = String::new();
    for line in lines {
        match line.split(',').next().and_then(|u| u.parse::<u64>().ok()) {
            Some(u) if u <= updates => {
                rows.push_str(line);
                rows.push_str(pad);
                rows.push('\n');
            }
            _ => break,
        }
    }
    rows
}

/// The rows of a resumed run's log `path` for updates `1..=updates`, refusing a log that does
/// not match the checkpoint: missing, not a regular file (a FIFO would block the read), not a
/// training log, a row that is not one (garbage, a line cut short inside the file), or — for
/// `log.csv` (`every_update`) — updates that do not run one by one up to the checkpoint's (a
/// deleted row, a short log). The last line alone may be cut short: a crash while it was
/// being appended leaves it so, and its update is one the checkpoint does not hold.
fn resume_log_rows(
    path: &Path,
    header: &str,
    updates: u64,
    every_update: bool,
) -> anyhow::Result<String> {
    let shown = path.display();
    let fix = "restore it, or start a new run from this one's weights with --init";
    let text = groundscope::files::read_regular_to_string(path)
        .map_err(|e| anyhow::anyhow!("--resume: {shown}: {e}; {fix}"))?;
    let mut lines: Vec<&str> = text.split('\n').collect();
    // What follows the last newline: empty, or a row cut short by a crash.
    lines.pop();
    let mut lines = lines.into_iter().enumerate();
    let pad = match lines.next() {
        Some((_, h)) if h == header => "",
        Some((_, h)) if h == EVAL_LOG_HEADER_V1 && header == EVAL_LOG_HEADER => ",",
        _ => anyhow::bail!(
            "--resume: {shown} is not a training log (its header is not {header:?}); {fix}"
        ),
    };
    let fields = header.split(',').count() - pad.len();
    let mut rows = String::new();
    let mut last = None;
    for (i, line) in lines {
        let update = line
            .split(',')
            .next()
            .and_then(|u| u.parse::<u64>().ok())
            .filter(|_| line.split(',').count() == fields);
        let Some(update) = update else {
            anyhow::bail!(
                "--resume: {shown} line {}: not a row of the log; {fix}",
                i + 1
            );
        };
        if update > updates {
            break;
        }
        let in_order = match last {
            None => true,
            Some(l) if every_update => update == l + 1,
            Some(l) => update >= l,
        };
        if !in_order {
            anyhow::bail!(
                "--resume: {shown} line {}: update {update} follows update {}; the log does not match the checkpoint; {fix}",
                i + 1,
                last.unwrap_or(0)
            );
        }
        last = Some(update);
        rows.push_str(line);
        rows.push_str(pad);
        rows.push('\n');
    }
    if every_update && updates > 0 && last != Some(updates) {
        anyhow::bail!(
            "--resume: {shown} ends at update {}, and the checkpoint is at update {updates}; the log does not match it; {fix}",
            last.unwrap_or(0)
        );
    }
    Ok(rows)
}

/// The tracked held-out evaluation of one update: a row per level, and for a `--levels`
/// run a row of their mean, appended to `eval_log.csv` in one write.
fn tracked_eval(
    trainer: &Trainer,
    episodes: u64,
    log: &UpdateLog,
    eval_file: &mut std::fs::File,
    quiet: bool,
) -> anyhow::Result<()> {
    let net = Net::new(trainer.model, trainer.params.detached())?;
    let mut rows = Vec::new();
    for e in trainer.levels.entries() {
        rows.push(groundscope::metrics::tracking::track(
            &net, &e.level, episodes, log.update, log.frames,
        )?);
    }
    if trainer.levels.is_mix() {
        rows.extend(TrackedEval::mean_of(&rows));
    }
    let text: String = rows
        .iter()
        .map(|r| groundscope::table::line(&r.record()))
        .collect();
    eval_file.write_all(text.as_bytes())?;
    if quiet {
        for row in &rows {
            println!(
                "eval update {} frames {} {}: greedy success {:.3} object acc_ng {:.3} colour acc_ng {:.3} ({:.1} s)",
                row.update,
                row.frames,
                row.level,
                row.greedy_success,
                row.object.1,
                row.color.1,
                row.eval_secs
            );
        }
    }
    Ok(())
}

/// Runs `train`.
pub fn run(args: &TrainArgs, matches: Option<&ArgMatches>) -> anyhow::Result<ExitStatus> {
    let variant = parse_variant(&args.model)?;
    let model = args.model_options.apply(ModelConfig {
        lstm_hidden: args.hidden,
        gru_hidden: args.hidden,
        ..ModelConfig::new(variant)
    })?;
    if args.save_interval == 0 {
        anyhow::bail!("--save-interval 0: must be at least 1 update");
    }
    if args.eval_interval > 0 && args.eval_episodes == 0 {
        anyhow::bail!(
            "--eval-episodes 0: must be at least 1 (--eval-interval 0 turns the tracked evaluation off)"
        );
    }
    if !args.resume {
        // Everything a new run can get wrong is refused before its directory is made.
        model.validate()?;
        let ppo = ppo_config(args, model.word_temperature.0)?;
        ppo.validate()?;
        let levels = level_mix(args)?;
        if ppo.imitate {
            check_labels(&levels)?;
        }
    }
    let created = !args.out.exists();
    let had_checkpoints = args.out.join("checkpoints").exists();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    // Held until this training ends (the system releases it if the process dies). A training
    // refused here touches nothing: the directory and its files are the holder's.
    let lock = match writable(&args.out).and_then(|()| lock_run(&args.out)) {
        Ok(lock) => lock,
        Err(e) => {
            if created {
                let _ = std::fs::remove_dir(&args.out);
            }
            return Err(e);
        }
    };
    let mut wrote = Vec::new();
    let result = train_in(args, matches, variant, model, &mut wrote);
    if result.is_err() && !args.resume && !run_dir::holds_run(&args.out) {
        // A new run that failed before its first checkpoint leaves nothing behind: the files
        // it wrote itself (never a log it found there), and its lock file while it still
        // holds it.
        for f in &wrote {
            let _ = std::fs::remove_file(f);
        }
        if !had_checkpoints {
            let _ = std::fs::remove_dir(args.out.join("checkpoints"));
        }
        if lock.created {
            let _ = std::fs::remove_file(args.out.join(RUN_LOCK));
        }
        drop(lock);
        if created {
            let _ = std::fs::remove_dir(&args.out);
        }
    }
    result
}

/// How many of each level's first training episodes `--imitate` runs the bot on before
/// training.
const LABEL_CHECK_EPISODES: u64 = 20;

/// Below this share of labelled steps a level gives imitation (almost) nothing to learn from.
const LABEL_SHARE_MIN: f64 = 0.01;

/// Imitation learns only from the steps the bot advises. The bot is run alone on each level's
/// first training episodes: a level where it labels under [`LABEL_SHARE_MIN`] of the steps
/// (it gives up at once or nearly, as on KeyInBox) is named in a warning with its share; a run
/// where every level is so is refused rather than trained on nothing.
fn check_labels(levels: &groundscope::policy::ppo::LevelMix) -> anyhow::Result<()> {
    use groundscope::policy::ppo::TRAIN_SEED_OFFSET;
    let seeds = TRAIN_SEED_OFFSET..TRAIN_SEED_OFFSET + LABEL_CHECK_EPISODES;
    let mut silent = Vec::new();
    for e in levels.entries() {
        let share = groundscope::bot::label_share(&e.level, seeds.clone())?;
        if share.share() < LABEL_SHARE_MIN {
            silent.push(format!(
                "{} ({} of {} steps labelled; the bot gave up on {} of {} episodes)",
                groundscope::metrics::report::level_name(&e.level),
                share.labelled,
                share.steps,
                share.gave_up,
                share.episodes
            ));
        }
    }
    if silent.len() == levels.entries().len() {
        anyhow::bail!(
            "--imitate: the bot labels almost nothing of {}: imitation would learn from no labelled frame",
            silent.join("; ")
        );
    }
    for what in silent {
        eprintln!(
            "groundscope: warning: --imitate: the bot labels almost nothing of {what}: its episodes give imitation no labels"
        );
    }
    Ok(())
}

/// Refuses a directory this process cannot write into.
fn writable(dir: &Path) -> anyhow::Result<()> {
    let probe = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("{} is not writable", dir.display()))?;
    drop(probe);
    Ok(())
}

/// `train` once its run directory exists.
fn train_in(
    args: &TrainArgs,
    matches: Option<&ArgMatches>,
    variant: groundscope::policy::Variant,
    model: ModelConfig,
    wrote: &mut Vec<PathBuf>,
) -> anyhow::Result<ExitStatus> {
    let log_path = args.out.join("log.csv");
    let eval_path = args.out.join("eval_log.csv");
    let (mut trainer, seed, kept, track) = if args.resume {
        let (trainer, seed, kept, saved) = resume_run(args, matches, variant)?;
        let u = trainer.state.updates;
        // Both logs are checked before either is rewritten.
        let rows = resume_log_rows(&log_path, LOG_HEADER, u, true)?;
        let eval_rows = resume_log_rows(&eval_path, EVAL_LOG_HEADER, u, false)?;
        write_atomic(&log_path, format!("{LOG_HEADER}\n{rows}").as_bytes())?;
        write_atomic(
            &eval_path,
            format!("{EVAL_LOG_HEADER}\n{eval_rows}").as_bytes(),
        )?;
        (trainer, seed, Some(kept), tracking(args, matches, saved))
    } else {
        if run_dir::holds_run(&args.out) {
            anyhow::bail!(
                "{} already holds a run; pass --resume to continue it or choose another --out",
                args.out.display()
            );
        }
        let levels = level_mix(args)?;
        let ppo = ppo_config(args, model.word_temperature.0)?;
        let (trainer, parent_rows, parent_evals) = if let Some(name) = &args.init {
            let trainer = warm_start(name, variant, levels, ppo, args, matches)?;
            let u = trainer.state.updates;
            (
                trainer,
                parent_log_rows(name, "log.csv", LOG_HEADER, u),
                parent_log_rows(name, "eval_log.csv", EVAL_LOG_HEADER, u),
            )
        } else {
            // A model for a BabyAI level gets rows for all of BabyAI's words.
            let vocab_size = levels
                .entries()
                .iter()
                .map(|e| ModelConfig::vocab_size_for(&e.level))
                .max()
                .unwrap_or(model.vocab_size);
            let model = ModelConfig {
                vocab_size,
                ..model
            };
            let params = Params::init(&model, args.seed)?;
            let trainer = Trainer::new(model, levels, ppo, params, args.seed)?;
            (trainer, String::new(), String::new())
        };
        wrote.push(log_path.clone());
        write_atomic(&log_path, format!("{LOG_HEADER}\n{parent_rows}").as_bytes())?;
        wrote.push(eval_path.clone());
        write_atomic(
            &eval_path,
            format!("{EVAL_LOG_HEADER}\n{parent_evals}").as_bytes(),
        )?;
        (trainer, args.seed, None, tracking(args, matches, None))
    };
    let open_append = |path: &Path| {
        std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .with_context(|| format!("opening {}", path.display()))
    };
    let mut log_file = open_append(&log_path)?;
    let mut eval_file = open_append(&eval_path)?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        // Ctrl-C, SIGTERM and SIGHUP (ctrlc's `termination` feature) all stop after the
        // current update and save. A second handler cannot be installed in tests that call
        // run twice; ignore that case.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst));
    }
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(args.frames)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} frames {msg} ETA {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar.set_position(trainer.state.frames);
    let start = Instant::now();
    let frames_at_start = trainer.state.frames;
    let mut last: Option<UpdateLog> = None;
    println!(
        "training {} on {} ({} parameters), {} frames/update, from frame {}",
        variant.name(),
        trainer.levels,
        trainer.params.count(),
        trainer.ppo.frames_per_update(),
        trainer.state.frames
    );
    while trainer.state.frames < args.frames && !stop.load(Ordering::SeqCst) {
        let log = trainer.update()?;
        let elapsed = start.elapsed().as_secs_f64();
        let fps = (trainer.state.frames - frames_at_start) as f64 / elapsed.max(1e-9);
        let row = groundscope::table::Record::new()
            .field(log.update)
            .field(log.frames)
            .field(format!("{fps:.0}"))
            .field(log.episodes)
            .field(format!("{:.4}", log.success_rate))
            .field(format!("{:.4}", log.mean_reward))
            .field(format!("{:.2}", log.mean_length))
            .field(format!("{:.5}", log.policy_loss))
            .field(format!("{:.5}", log.value_loss))
            .field(format!("{:.4}", log.entropy))
            .field(format!("{:.4}", log.grad_norm))
            .field(format!("{elapsed:.1}"));
        log_file.write_all(groundscope::table::line(&row).as_bytes())?;
        bar.set_position(trainer.state.frames);
        bar.set_message(format!(
            "{fps:.0} fps, success {:.2}, reward {:.3}",
            log.success_rate, log.mean_reward
        ));
        if args.quiet && log.update % 10 == 0 {
            // The grounding term is shown only where it is trained.
            let ground = if trainer.ppo.ground_loss > 0.0 {
                format!(" ground {:.3}", log.ground_loss)
            } else {
                String::new()
            };
            println!(
                "update {} frames {} fps {fps:.0} success {:.3} reward {:.3} entropy {:.3}{ground}",
                log.update, log.frames, log.success_rate, log.mean_reward, log.entropy
            );
        }
        if track.eval_interval > 0 && log.update % track.eval_interval == 0 {
            tracked_eval(
                &trainer,
                track.eval_episodes,
                &log,
                &mut eval_file,
                args.quiet,
            )?;
        }
        if log.update % track.save_interval.unwrap_or(args.save_interval) == 0 {
            save_run(
                &trainer,
                &args.out,
                training_state(&trainer, seed, Some(&log), None),
                track,
            )?;
        }
        last = Some(log);
    }
    // A resumed run with nothing left to do keeps its checkpoint as it is.
    if last.is_some() || kept.is_none() {
        save_run(
            &trainer,
            &args.out,
            training_state(&trainer, seed, last.as_ref(), kept.as_ref()),
            track,
        )?;
    }
    bar.finish_and_clear();
    let why = if stop.load(Ordering::SeqCst) {
        "interrupted; saved"
    } else {
        "done"
    };
    println!(
        "{why}: {} frames, {} updates, last success {:.3}, reward {:.3}; checkpoint {}",
        trainer.state.frames,
        trainer.state.updates,
        last.as_ref().map_or(f64::NAN, |l| l.success_rate),
        last.as_ref().map_or(f64::NAN, |l| l.mean_reward),
        args.out.join("model").display()
    );
    Ok(ExitStatus::Success)
}
