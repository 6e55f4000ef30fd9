//! `groundscope bench levels`: the evaluation sweep over BabyAI levels against the paper's
//! sweep, time per episode step, one thread, as one JSON line (issue #44's target: the levels
//! within 2× the paper sweep's time per step).

use std::time::Instant;

use clap::Args;
use groundscope::env::LevelConfig;
use groundscope::episode::ActionMode;
use groundscope::metrics::sweep::{EvalOptions, evaluate_cell_explored};
use groundscope::policy::Agent;

use crate::ExitStatus;

/// Twenty registered levels whose missions the bundled checkpoints can read (the paper's words):
/// one room and several, small and large, go to and pick up, locations, a locked corridor.
const DEFAULT_LEVELS: [&str; 20] = [
    "BabyAI-GoToRedBallGrey-v0",
    "BabyAI-GoToRedBall-v0",
    "BabyAI-GoToRedBallNoDists-v0",
    "BabyAI-GoToRedBlueBall-v0",
    "BabyAI-GoToObj-v0",
    "BabyAI-GoToObjS4-v0",
    "BabyAI-GoToObjS6-v1",
    "BabyAI-GoToLocal-v0",
    "BabyAI-GoToLocalS6N4-v0",
    "BabyAI-PickupLoc-v0",
    "BabyAI-PickupDist-v0",
    "BabyAI-OneRoomS8-v0",
    "BabyAI-OneRoomS12-v0",
    "BabyAI-OneRoomS16-v0",
    "BabyAI-GoTo-v0",
    "BabyAI-GoToObjMaze-v0",
    "BabyAI-GoToObjMazeS4-v0",
    "BabyAI-Pickup-v0",
    "BabyAI-FindObjS5-v0",
    "BabyAI-KeyCorridorS3R3-v0",
];

/// `bench levels`.
#[derive(Debug, Args)]
pub struct BenchLevelsArgs {
    /// The checkpoint (NAME, run directory, bundled:…, FILE.onnx or bot).
    #[arg(long, default_value = "bundled:attention", value_name = "NAME")]
    pub checkpoint: String,
    /// The levels to sweep [default: twenty levels of the paper's words, one room to nine].
    #[arg(long, value_delimiter = ',', value_name = "ID,ID,...")]
    pub levels: Vec<String>,
    /// Evaluation seeds per cell, on both sweeps.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub seeds: u64,
    /// Episodes per seed, on both sweeps.
    #[arg(long, default_value_t = 20, allow_negative_numbers = true)]
    pub episodes: u64,
    /// `--done` / `--no-done` on the BabyAI levels (default: their registered mode).
    #[command(flatten)]
    pub done: super::flags::DoneArgs,
}

/// Time and episode steps of one sweep.
fn sweep(
    agent: &Agent,
    cells: &[LevelConfig],
    seeds: u64,
    episodes: u64,
) -> anyhow::Result<(f64, u64)> {
    let opts = EvalOptions {
        alpha: 0.5,
        mode: ActionMode::Greedy,
        saliency: false,
    };
    let start = Instant::now();
    let mut steps = 0u64;
    for level in cells {
        let eps = evaluate_cell_explored(
            agent.acting(),
            level,
            0..seeds,
            episodes,
            &opts,
            &mut |_| {},
        )?;
        steps += eps.iter().map(|(e, _)| u64::from(e.length)).sum::<u64>();
    }
    Ok((start.elapsed().as_secs_f64(), steps))
}

/// Runs `bench levels`.
pub fn run(args: &BenchLevelsArgs) -> anyhow::Result<ExitStatus> {
    if !(1..=100).contains(&args.seeds) || !(1..=10_000).contains(&args.episodes) {
        anyhow::bail!("--seeds must be in 1..=100 and --episodes in 1..=10000");
    }
    let agent = Agent::load(&args.checkpoint)?;
    let base = agent.level();
    let ids: Vec<String> = if args.levels.is_empty() {
        DEFAULT_LEVELS.iter().map(|s| (*s).to_owned()).collect()
    } else {
        args.levels.clone()
    };
    let levels: Vec<LevelConfig> = super::flags::babyai_levels(&ids, base)?
        .into_iter()
        .map(|l| args.done.apply(l))
        .collect();
    // The paper's default 20-cell sweep.
    let paper = super::flags::paper_levels(
        LevelConfig {
            babyai: None,
            ..base
        },
        &[8, 10, 12, 14, 16],
        &[4, 6, 8, 10],
    )?;
    // The paper's sweep first and last, the levels between: drift on a shared machine shows.
    let (p1, ps1) = sweep(&agent, &paper, args.seeds, args.episodes)?;
    let (l, ls) = sweep(&agent, &levels, args.seeds, args.episodes)?;
    let (p2, ps2) = sweep(&agent, &paper, args.seeds, args.episodes)?;
    let paper_us = 1e6 * (p1 + p2) / (ps1 + ps2).max(1) as f64;
    let levels_us = 1e6 * l / ls.max(1) as f64;
    println!(
        "{}",
        serde_json::json!({
            "bench": "levels",
            "checkpoint": args.checkpoint,
            "levels": ids,
            "cells": { "levels": levels.len(), "paper": paper.len() },
            "seeds": args.seeds,
            "episodes_per_seed": args.episodes,
            "paper": { "secs": [p1, p2], "steps": ps1 + ps2, "us_per_step": paper_us },
            "levels_sweep": { "secs": l, "steps": ls, "us_per_step": levels_us },
            "ratio_per_step": levels_us / paper_us,
            "target": 2.0,
        })
    );
    Ok(ExitStatus::Success)
}
