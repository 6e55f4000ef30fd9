//! `groundscope validate`: the tracked held-out evaluation of `train --eval-interval`, run on
//! saved checkpoints — so a checkpoint (a snapshot of a run, another run's model, a bundled
//! one) can be judged on the same validation levels as the runs' `eval_log.csv`, never on the
//! test seeds of `eval`.

use std::path::PathBuf;

use clap::Args;
use groundscope::files::{OutputKind, output_kind, parent_dir};
use groundscope::metrics::tracking::{EVAL_LOG_HEADER, track};
use groundscope::policy::Agent;
use groundscope::policy::checkpoint::write_atomic;
use groundscope::table::{Record, Table};

use crate::ExitStatus;

/// `groundscope validate`.
#[derive(Debug, Args)]
#[command(
    after_long_help = "EXAMPLES:\n  groundscope validate bundled:attention runs/att/model --episodes 500\n  groundscope validate snapshots/att/*/model --out choice.csv"
)]
pub struct ValidateArgs {
    /// Checkpoints: NAME (NAME.json + NAME.safetensors), a run directory (its model) or
    /// bundled:attention / bundled:baseline. Each is evaluated on its own training level.
    #[arg(required = true, value_name = "NAME")]
    pub checkpoints: Vec<String>,
    /// Held-out episodes per checkpoint (level seeds 2^31 + e, those of `train`'s tracking).
    #[arg(long, default_value_t = 500, allow_negative_numbers = true)]
    pub episodes: u64,
    /// Write the rows to this CSV file instead of stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// Runs `validate`: every checkpoint is loaded before any is evaluated, and the output is
/// written whole at the end, so bad input leaves no partial file.
pub fn run(args: &ValidateArgs) -> anyhow::Result<ExitStatus> {
    if args.episodes == 0 || args.episodes > groundscope::env::seeds::EPISODES_PER_EVAL_SEED {
        anyhow::bail!("--episodes {} must be between 1 and 1000000", args.episodes);
    }
    if let Some(path) = &args.out {
        // Found wrong now, not after every checkpoint has been evaluated.
        super::check_extension(path, "csv", "--out")?;
        let cannot = |e: std::io::Error| {
            anyhow::anyhow!("--out {}: cannot write there: {e}", path.display())
        };
        // A file is replaced through a temporary beside it (a device or FIFO is written in place).
        if let OutputKind::Replace(dest) = output_kind(path).map_err(cannot)? {
            tempfile::NamedTempFile::new_in(parent_dir(&dest)).map_err(cannot)?;
        }
    }
    let mut ckpts = Vec::new();
    for name in &args.checkpoints {
        ckpts.push((name, Agent::load(name)?));
    }
    let mut table = Table::new(&format!("checkpoint,{EVAL_LOG_HEADER}"));
    for (name, agent) in ckpts {
        // An imported graph's metadata carries no training counters: its row says 0.
        let (updates, frames) = match &agent {
            Agent::Native(ckpt, _) => (ckpt.meta.training.updates, ckpt.meta.training.frames),
            Agent::Onnx(_) | Agent::Bot(_) => (0, 0),
        };
        let row = track(
            agent.acting(),
            &agent.level(),
            args.episodes,
            updates,
            frames,
        )?;
        // The name is quoted where it holds a comma, a quote or a line break.
        table.push(&Record::new().field(name).extend(row.record()));
    }
    let text = table.finish();
    match &args.out {
        Some(path) => write_atomic(path, text.as_bytes())?,
        None => print!("{text}"),
    }
    Ok(ExitStatus::Success)
}
