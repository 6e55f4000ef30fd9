//! `groundscope bench …`: speed benchmarks printing one JSON line each.

use std::hint::black_box;
use std::time::Instant;

use clap::Subcommand;
use groundscope::env::{Action, LevelConfig};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::ExitStatus;

/// `bench` subcommands.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Environment steps/s: random actions with auto-reset on the paper's level, one thread,
    /// observation included.
    Env {
        /// Steps to time.
        #[arg(long, default_value_t = 5_000_000)]
        steps: u64,
    },
}

/// Runs a benchmark.
pub fn run(cmd: BenchCommand) -> anyhow::Result<ExitStatus> {
    match cmd {
        BenchCommand::Env { steps } => bench_env(steps),
    }
}

fn bench_env(steps: u64) -> anyhow::Result<ExitStatus> {
    let cfg = LevelConfig::default();
    let mut rng = Pcg64Mcg::seed_from_u64(0);
    let mut seed = 0;
    let mut world = cfg.generate(seed)?;
    let mut episodes = 1u64;
    let start = Instant::now();
    for _ in 0..steps {
        let action = Action::ALL[rng.random_range(0..Action::COUNT)];
        let out = world.step(action)?;
        black_box(world.observe());
        if out.terminated || out.truncated {
            seed += 1;
            episodes += 1;
            world = cfg.generate(seed)?;
        }
    }
    let secs = start.elapsed().as_secs_f64();
    let line = serde_json::json!({
        "bench": "env",
        "steps_per_sec": (steps as f64 / secs).round(),
        "level": cfg.to_string(),
        "steps": steps,
        "episodes": episodes,
        "threads": 1,
        "elapsed_secs": secs,
    });
    println!("{line}");
    Ok(ExitStatus::Success)
}
