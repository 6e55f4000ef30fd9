//! `groundscope init` and `groundscope replay`.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use groundscope::policy::{Checkpoint, ModelConfig, Params, TrainingState, Variant};

use crate::ExitStatus;
use crate::cli::env_cmd::LevelArgs;
use crate::cli::model_options::ModelOptions;

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
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    pub seed: u64,
    /// Checkpoint name: writes NAME.safetensors and NAME.json.
    #[arg(long, value_name = "NAME")]
    pub out: PathBuf,
    #[command(flatten)]
    pub model_options: ModelOptions,
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
    // A model made for a BabyAI level gets rows for all of BabyAI's words, as `train --level`
    // gives it: the paper's 25 would refuse the level it was made for.
    let cfg = args.model_options.apply(ModelConfig {
        vocab_size: ModelConfig::vocab_size_for(&level),
        ..ModelConfig::new(variant)
    })?;
    cfg.validate()?;
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

/// The level of one cell of a sweep: `base` with `size` and `objects`, checked; an error
/// names both flags.
pub fn sweep_level(
    base: groundscope::env::LevelConfig,
    size: usize,
    objects: usize,
) -> anyhow::Result<groundscope::env::LevelConfig> {
    level_from(base, Some(size), Some(objects))
        .map_err(|e| anyhow::anyhow!("--sizes {size} --objects {objects}: {e}"))
}

/// A training level with the room size and object count given on the command line, checked.
pub fn level_from(
    mut level: groundscope::env::LevelConfig,
    size: Option<usize>,
    objects: Option<usize>,
) -> anyhow::Result<groundscope::env::LevelConfig> {
    if let Some(s) = size {
        level.room_size = s;
    }
    if let Some(n) = objects {
        level.n_objects = n;
    }
    level.validate()?;
    Ok(level)
}
