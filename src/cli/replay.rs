//! `groundscope replay`: run a checkpoint on episodes and write what it saw and did — a JSON
//! trace, Rerun (file, spawned or running viewer) and/or MCAP.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use anyhow::Context as _;
use clap::Args;
use groundscope::episode::{ActionMode, EpisodeSpec, EpisodeTrace, run_episode};
use groundscope::record::{RerunTargets, StopFlag, record_rerun, write_mcap};

use crate::ExitStatus;
use crate::cli::check_extension;
use crate::cli::policy_cmd::{level_with, load_checkpoint};

/// The default `--connect` URL: a viewer on this machine.
const DEFAULT_VIEWER_URL: &str = "rerun+http://127.0.0.1:9876/proxy";

/// `groundscope replay`.
#[derive(Debug, Args)]
#[command(after_long_help = "EXAMPLES:\n  \
    groundscope replay --seed 3 --spawn\n  \
    groundscope replay --seed 3 --episodes 5 --save five.rrd --mcap five.mcap\n  \
    groundscope replay --checkpoint bundled:baseline --mission \"go to the red ball\" --save red.rrd\n  \
    groundscope replay --checkpoint runs/untrained --seed 3 --trace out.json")]
pub struct ReplayArgs {
    /// Checkpoint: NAME (NAME.json + NAME.safetensors) or bundled:attention / bundled:baseline
    /// [default: bundled:attention].
    #[arg(long, value_name = "NAME")]
    pub checkpoint: Option<String>,
    /// Level seed (of the first episode).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Number of episodes, on consecutive seeds from --seed.
    #[arg(long, default_value_t = 1, value_name = "K")]
    pub episodes: u64,
    /// Replace the generated mission (vocabulary words only).
    #[arg(long, value_name = "TEXT")]
    pub mission: Option<String>,
    /// Sample actions instead of taking the most probable one.
    #[arg(long)]
    pub sample: bool,
    /// Room size; defaults to the level the checkpoint was trained on.
    #[arg(long, value_name = "S")]
    pub size: Option<usize>,
    /// Number of objects; defaults to the checkpoint's level.
    #[arg(long, value_name = "N")]
    pub objects: Option<usize>,
    /// Write the episode trace here (JSON; one episode only).
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// Write a Rerun recording (.rrd).
    #[arg(long, value_name = "FILE.rrd")]
    pub save: Option<PathBuf>,
    /// Start a Rerun viewer (`rerun` on PATH; `pip install rerun-sdk==0.36.3`) and stream to it.
    #[arg(long)]
    pub spawn: bool,
    /// Stream to a running Rerun viewer [URL default: rerun+http://127.0.0.1:9876/proxy].
    #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = DEFAULT_VIEWER_URL)]
    pub connect: Option<String>,
    /// Write the episodes as MCAP (Foxglove / Lichtblick).
    #[arg(long, value_name = "FILE.mcap")]
    pub mcap: Option<PathBuf>,
    /// Threshold fraction α of the grounding hit/miss marks (τ = α / n).
    #[arg(long, default_value_t = 0.5)]
    pub alpha: f64,
}

/// The most episodes one `replay` holds and records.
const MAX_EPISODES: u64 = 1000;

/// Runs `replay`.
pub fn replay(args: &ReplayArgs) -> anyhow::Result<ExitStatus> {
    if args.episodes == 0 || args.episodes > MAX_EPISODES {
        // Episodes are kept in memory until they are recorded (about 1 MB each at worst).
        anyhow::bail!(
            "--episodes {}: must be in 1..={MAX_EPISODES} (record more as several files)",
            args.episodes
        );
    }
    if args.trace.is_some() && args.episodes > 1 {
        anyhow::bail!("--trace writes one episode; drop --episodes or use --save / --mcap");
    }
    if !(0.0..=1.0).contains(&args.alpha) {
        anyhow::bail!("--alpha {} is outside [0, 1]", args.alpha);
    }
    if let Some(p) = &args.save {
        check_extension(p, "rrd", "--save")?;
    }
    if let Some(p) = &args.mcap {
        check_extension(p, "mcap", "--mcap")?;
    }
    let (ckpt, name) = load_checkpoint(args.checkpoint.as_deref())?;
    let level = level_with(&ckpt, args.size, args.objects)?;
    let mode = if args.sample {
        ActionMode::Sampled
    } else {
        ActionMode::Greedy
    };
    let last = args
        .seed
        .checked_add(args.episodes - 1)
        .context("--seed + --episodes overflows")?;
    let mut episodes: Vec<EpisodeTrace> = Vec::new();
    for seed in args.seed..=last {
        let spec = EpisodeSpec {
            level,
            seed,
            mission: args.mission.clone(),
            mode,
        };
        let trace = run_episode(&ckpt, &name, &spec)?;
        println!(
            "{} on {level} seed {seed}: \"{}\" → {} in {} steps, reward {:.3}",
            ckpt.meta.model.variant.name(),
            trace.mission,
            if trace.success() {
                "success"
            } else {
                "failure"
            },
            trace.steps.len(),
            trace.total_reward()
        );
        episodes.push(trace);
    }
    let stop: StopFlag = Arc::new(AtomicBool::new(false));
    let wants_record = args.save.is_some() || args.spawn || args.connect.is_some();
    if wants_record || args.mcap.is_some() {
        let s = stop.clone();
        // A second handler cannot be installed in the same process (tests call `run` once).
        let _ = ctrlc::set_handler(move || s.store(true, Ordering::Relaxed));
    }
    // All outputs or none: a later output that fails removes the ones this run wrote.
    let mut written = Written(Vec::new());
    if wants_record {
        let targets = RerunTargets {
            save: args.save.clone(),
            spawn: args.spawn,
            connect: args.connect.clone(),
        };
        let t0 = Instant::now();
        let stats = record_rerun(&episodes, &targets, args.alpha, Some(&stop))?;
        let secs = t0.elapsed().as_secs_f64();
        if let Some(p) = &args.save {
            written.0.push(p.clone());
            let bytes = std::fs::metadata(p).map_or(0, |m| m.len());
            println!(
                "wrote {} ({} episodes, {} steps, {bytes} bytes = {:.1} KB/step, {:.0} steps/s)",
                p.display(),
                stats.episodes,
                stats.steps,
                bytes as f64 / 1000.0 / stats.steps.max(1) as f64,
                stats.steps as f64 / secs.max(1e-9)
            );
        }
        if args.spawn || args.connect.is_some() {
            println!("streamed {} steps to the Rerun viewer", stats.steps);
        }
    }
    if let Some(path) = &args.mcap {
        let t0 = Instant::now();
        let stats = write_mcap(&episodes, path, args.alpha, Some(&stop))?;
        written.0.push(path.clone());
        let secs = t0.elapsed().as_secs_f64();
        let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
        println!(
            "wrote {} ({} steps on {} topics, {bytes} bytes = {:.1} KB/step, {:.0} steps/s)",
            path.display(),
            stats.steps,
            stats.messages.len(),
            bytes as f64 / 1000.0 / stats.steps.max(1) as f64,
            stats.steps as f64 / secs.max(1e-9)
        );
    }
    if let (Some(path), [trace]) = (&args.trace, episodes.as_slice()) {
        trace.save_json(path)?;
        println!("wrote {}", path.display());
    }
    written.0.clear();
    Ok(ExitStatus::Success)
}

/// Files written by this run, removed again if it ends with an error before clearing them.
struct Written(Vec<PathBuf>);

impl Drop for Written {
    fn drop(&mut self) {
        for p in &self.0 {
            if std::fs::metadata(p).is_ok_and(|m| m.is_file()) {
                let _ = std::fs::remove_file(p);
            }
        }
    }
}
