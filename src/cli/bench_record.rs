//! `groundscope bench record`: recording speed and size over many short episodes, or (with
//! `--level`) the memory of recording one long episode as `replay --save` / `--mcap` do —
//! each format in a process of its own so that each gets its own peak (`VmHWM`), beside a
//! process that only runs the episode.

use std::time::Instant;

use anyhow::Context as _;
use clap::Args;
use groundscope::episode::{ActionMode, EpisodeSpec, initial_world, run_episode, run_from};
use groundscope::record::{
    McapRecorder, RerunRecorder, RerunTargets, block_starts, mission_words, record_rerun,
    scene_block, word_paths, write_mcap,
};

use crate::ExitStatus;

/// The peak memory a long episode's recording is held to (issue #66), in bytes.
const TARGET_PEAK_BYTES: u64 = 300 * 1024 * 1024;

/// `bench record`'s flags.
#[derive(Debug, Args)]
pub struct BenchRecordArgs {
    /// Episodes to record (without `--level`).
    #[arg(long, default_value_t = 50, allow_negative_numbers = true)]
    episodes: u64,
    /// One long episode of this BabyAI level instead, recorded block by block as `replay`
    /// records it (e.g. BabyAI-BossLevel-v0, whose seed 3 runs to its 1,728-step limit).
    #[arg(long, value_name = "ID")]
    level: Option<String>,
    /// The level seed (with `--level`).
    #[arg(long, default_value_t = 3, allow_negative_numbers = true)]
    seed: u64,
    /// Record in this process only: `none`, `rrd` or `mcap` (what each format's own process
    /// runs).
    #[arg(long, hide = true, value_name = "FORMAT")]
    in_process: Option<String>,
}

/// Runs the benchmark.
pub fn run(args: &BenchRecordArgs) -> anyhow::Result<ExitStatus> {
    let Some(level) = &args.level else {
        if !(1..=10_000).contains(&args.episodes) {
            anyhow::bail!("--episodes {}: must be in 1..=10000", args.episodes);
        }
        return short_episodes(args.episodes);
    };
    let level = groundscope::env::LevelConfig::from_id(level)?;
    if let Some(format) = &args.in_process {
        println!("{}", long_episode(level, args.seed, format)?);
        return Ok(ExitStatus::Success);
    }
    let exe = std::env::current_exe().context("finding this program to time each format")?;
    for format in ["none", "rrd", "mcap"] {
        let out = std::process::Command::new(&exe)
            .args(["bench", "record", "--level", &level.id()])
            .args(["--seed", &args.seed.to_string(), "--in-process", format])
            .output()
            .context("running the format's own process")?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            anyhow::bail!(
                "{format}: {}",
                err.trim().trim_start_matches("groundscope: ")
            );
        }
        print!("{}", String::from_utf8_lossy(&out.stdout));
    }
    Ok(ExitStatus::Success)
}

/// Runs `level`'s episode of `seed` with the model `replay` opens there and records it in
/// `format` (`none`: not at all), block by block; one JSON line.
fn long_episode(
    level: groundscope::env::LevelConfig,
    seed: u64,
    format: &str,
) -> anyhow::Result<serde_json::Value> {
    if !["none", "rrd", "mcap"].contains(&format) {
        anyhow::bail!("--in-process {format:?} is not none, rrd or mcap");
    }
    let name = groundscope::policy::bundled::BABYAI;
    let agent = groundscope::policy::Agent::load(name)?;
    let spec = EpisodeSpec {
        level,
        seed,
        mission: None,
        mode: ActionMode::Greedy,
    };
    let started = Instant::now();
    let trace = run_from(agent.acting(), name, &spec, initial_world(&spec)?)?;
    let run_secs = started.elapsed().as_secs_f64();
    let dir = tempfile::tempdir()?;
    let path = dir.path().join(format!("long.{format}"));
    let written = Instant::now();
    match format {
        "rrd" => {
            let paths = word_paths([mission_words(trace.words(), &trace.final_world)]);
            let targets = RerunTargets {
                save: Some(path.clone()),
                ..RerunTargets::default()
            };
            let mut r = RerunRecorder::start(&targets, &trace, 1, &paths)?;
            for first in block_starts(&trace) {
                r.push_block(&trace, first, &scene_block(&trace, first, 0.5), None)?;
            }
            r.finish()?;
        }
        "mcap" => {
            let mut m = McapRecorder::create(&path)?;
            for first in block_starts(&trace) {
                m.push_block(&trace, first, &scene_block(&trace, first, 0.5), None)?;
            }
            m.finish()?;
        }
        _ => {}
    }
    let write_secs = written.elapsed().as_secs_f64();
    let bytes = std::fs::metadata(&path).map_or(0, |m| m.len());
    let peak = super::bench::peak_rss_bytes();
    Ok(serde_json::json!({
        "bench": "record_long",
        "format": format,
        "level": level.id(),
        "seed": seed,
        "checkpoint": name,
        "steps": trace.steps.len(),
        "run_secs": (run_secs * 1000.0).round() / 1000.0,
        "write_secs": (write_secs * 1000.0).round() / 1000.0,
        "bytes": bytes,
        "peak_rss_bytes": peak,
        "target_peak_bytes": TARGET_PEAK_BYTES,
        "within_target": peak.map(|p| p <= TARGET_PEAK_BYTES),
    }))
}

/// The bundled attention checkpoint's `episodes` on consecutive seeds, run first, then
/// written as `.rrd` and as MCAP: steps/s and bytes/step of each.
fn short_episodes(episodes: u64) -> anyhow::Result<ExitStatus> {
    let (ckpt, name) = crate::cli::policy_cmd::load_checkpoint(None)?;
    let eps = (0..episodes)
        .map(|seed| {
            let spec = EpisodeSpec {
                level: ckpt.meta.level,
                seed,
                mission: None,
                mode: ActionMode::Greedy,
            };
            run_episode(&ckpt, &name, &spec)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let steps: usize = eps.iter().map(|e| e.steps.len()).sum();
    let dir = tempfile::tempdir()?;
    for (format, path) in [
        ("rrd", dir.path().join("b.rrd")),
        ("mcap", dir.path().join("b.mcap")),
    ] {
        let start = Instant::now();
        if format == "rrd" {
            let targets = RerunTargets {
                save: Some(path.clone()),
                ..RerunTargets::default()
            };
            record_rerun(&eps, &targets, 0.5, None)?;
        } else {
            write_mcap(&eps, &path, 0.5, None)?;
        }
        let secs = start.elapsed().as_secs_f64();
        let bytes = std::fs::metadata(&path)?.len();
        let line = serde_json::json!({
            "bench": "record",
            "format": format,
            "steps_per_sec": (steps as f64 / secs).round(),
            "bytes_per_step": (bytes as f64 / steps as f64).round(),
            "episodes": episodes,
            "steps": steps,
            "bytes": bytes,
            "elapsed_secs": secs,
        });
        println!("{line}");
    }
    Ok(ExitStatus::Success)
}
