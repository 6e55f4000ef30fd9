//! `groundscope init` and `groundscope replay`.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use groundscope::episode::{ActionMode, EpisodeSpec, run_episode};
use groundscope::policy::{Checkpoint, ModelConfig, Params, TrainingState, Variant};

use crate::ExitStatus;
use crate::cli::env_cmd::LevelArgs;

/// `groundscope init`.
#[derive(Debug, Args)]
#[command(
    after_long_help = "EXAMPLES:\n  groundscope init --model attention --seed 1 --out runs/untrained"
)]
pub struct InitArgs {
    /// attention or baseline.
    #[arg(long, value_name = "MODEL", default_value = "attention")]
    pub model: String,
    /// Initialisation seed (same seed → identical bytes).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Checkpoint name: writes NAME.safetensors and NAME.json.
    #[arg(long, value_name = "NAME")]
    pub out: PathBuf,
    #[command(flatten)]
    pub level: LevelArgs,
}

/// Parses a `--model` value.
pub fn parse_variant(s: &str) -> anyhow::Result<Variant> {
    Variant::parse(s).with_context(|| format!("--model {s:?} is not attention or baseline"))
}

/// Runs `init`.
pub fn init(args: &InitArgs) -> anyhow::Result<ExitStatus> {
    let variant = parse_variant(&args.model)?;
    let level = args.level.config()?;
    let cfg = ModelConfig::new(variant);
    let params = Params::init(&cfg, args.seed)?;
    let n = params.count();
    let training = TrainingState {
        seed: args.seed,
        ..TrainingState::default()
    };
    let mut ckpt = Checkpoint::new(cfg, level, training, params);
    ckpt.save(&args.out)?;
    println!(
        "wrote {} checkpoint {} ({n} parameters, seed {})",
        variant.name(),
        args.out.display(),
        args.seed
    );
    Ok(ExitStatus::Success)
}

/// Loads the checkpoint named on the command line, or the bundled attention model.
pub fn load_checkpoint(spec: Option<&str>) -> anyhow::Result<(Checkpoint, String)> {
    let spec = spec.map_or_else(
        || groundscope::policy::bundled::names()[0].clone(),
        str::to_owned,
    );
    let ckpt = groundscope::policy::bundled::load(&spec)?;
    Ok((ckpt, spec))
}

/// `groundscope replay`.
#[derive(Debug, Args)]
#[command(
    after_long_help = "EXAMPLES:\n  groundscope replay --checkpoint runs/untrained --seed 3 --trace out.json"
)]
pub struct ReplayArgs {
    /// Checkpoint: NAME (NAME.json + NAME.safetensors) or bundled:attention / bundled:baseline
    /// [default: bundled:attention].
    #[arg(long, value_name = "NAME")]
    pub checkpoint: Option<String>,
    /// Level seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Replace the generated mission (vocabulary words only).
    #[arg(long, value_name = "TEXT")]
    pub mission: Option<String>,
    /// Sample actions instead of taking the most probable one.
    #[arg(long)]
    pub sample: bool,
    /// Level; defaults to the level the checkpoint was trained on.
    #[arg(long, value_name = "S")]
    pub size: Option<usize>,
    /// Number of objects; defaults to the checkpoint's level.
    #[arg(long, value_name = "N")]
    pub objects: Option<usize>,
    /// Write the episode trace here (JSON).
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
}

/// Runs `replay`.
pub fn replay(args: &ReplayArgs) -> anyhow::Result<ExitStatus> {
    let (ckpt, name) = load_checkpoint(args.checkpoint.as_deref())?;
    let mut level = ckpt.meta.level;
    if let Some(s) = args.size {
        level.room_size = s;
    }
    if let Some(n) = args.objects {
        level.n_objects = n;
    }
    level.validate()?;
    let spec = EpisodeSpec {
        level,
        seed: args.seed,
        mission: args.mission.clone(),
        mode: if args.sample {
            ActionMode::Sampled
        } else {
            ActionMode::Greedy
        },
    };
    let trace = run_episode(&ckpt, &name, &spec)?;
    println!(
        "{} on {level} seed {}: \"{}\" → {} in {} steps, reward {:.3}",
        ckpt.meta.model.variant.name(),
        args.seed,
        trace.mission,
        if trace.success() {
            "success"
        } else {
            "failure"
        },
        trace.steps.len(),
        trace.total_reward()
    );
    if let Some(path) = &args.trace {
        trace.save_json(path)?;
        println!("wrote {}", path.display());
    }
    Ok(ExitStatus::Success)
}
