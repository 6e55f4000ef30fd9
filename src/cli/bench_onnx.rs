//! `groundscope bench onnx`: an evaluation sweep on an ONNX graph and on a native checkpoint,
//! side by side in one process, and where the graph's time goes.

use std::time::Instant;

use clap::Args;
use groundscope::metrics::sweep::evaluate_cell;
use groundscope::policy::Agent;

use super::flags::SweepArgs;
use crate::ExitStatus;

/// `bench onnx`.
#[derive(Debug, Args)]
pub struct BenchOnnxArgs {
    /// The ONNX graph.
    #[arg(long, value_name = "FILE.onnx")]
    pub checkpoint: String,
    /// The native checkpoint it is compared with (the one it was exported from, for a ratio
    /// that measures the runtime alone).
    #[arg(long, value_name = "NAME", default_value = "bundled:attention")]
    pub native: String,
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Times each sweep runs, alternating native and ONNX; the fastest of each is reported.
    #[arg(long, default_value_t = 2, allow_negative_numbers = true)]
    pub rounds: u32,
}

/// One sweep of `agent`, one thread; returns its seconds and the steps taken.
fn sweep(agent: &Agent, args: &BenchOnnxArgs) -> anyhow::Result<(f64, u64)> {
    let start = Instant::now();
    let mut steps = 0u64;
    for level in args.sweep.levels(agent.level())? {
        let eps = evaluate_cell(
            agent.acting(),
            &level,
            args.sweep.seed_range(),
            args.sweep.episodes,
            0.5,
            args.sweep.mode(),
            &mut |_| {},
        )?;
        steps += eps.iter().map(|e| u64::from(e.length)).sum::<u64>();
    }
    Ok((start.elapsed().as_secs_f64(), steps))
}

/// Runs `bench onnx`.
pub fn run(args: &BenchOnnxArgs) -> anyhow::Result<ExitStatus> {
    args.sweep.check()?;
    if !(1..=10).contains(&args.rounds) {
        anyhow::bail!("--rounds {}: must be in 1..=10", args.rounds);
    }
    let graph = Agent::load(&args.checkpoint)?;
    let Agent::Onnx(onnx) = &graph else {
        anyhow::bail!(
            "--checkpoint {}: not an ONNX graph (a file ending in .onnx)",
            args.checkpoint
        );
    };
    let native = Agent::load(&args.native)?;
    let (mut native_secs, mut onnx_secs) = (f64::INFINITY, f64::INFINITY);
    let (mut native_steps, mut onnx_steps) = (0, 0);
    let mut split = onnx.step_times();
    for _ in 0..args.rounds {
        let (secs, steps) = sweep(&native, args)?;
        (native_secs, native_steps) = (native_secs.min(secs), steps);
        // Each round starts with no mission encoded, as a fresh process would.
        onnx.forget_missions();
        let before = onnx.step_times();
        let (secs, steps) = sweep(&graph, args)?;
        if secs < onnx_secs {
            split = onnx.step_times().since(&before);
        }
        (onnx_secs, onnx_steps) = (onnx_secs.min(secs), steps);
    }
    let line = serde_json::json!({
        "bench": "onnx",
        "checkpoint": args.checkpoint,
        "native": args.native,
        "cells": args.sweep.sizes.len() * args.sweep.objects.len(),
        "episodes": args.sweep.sizes.len() as u64 * args.sweep.objects.len() as u64 * args.sweep.seeds * args.sweep.episodes,
        "native_env_steps": native_steps,
        "onnx_env_steps": onnx_steps,
        "native_secs": native_secs,
        "onnx_secs": onnx_secs,
        "ratio": onnx_secs / native_secs,
        "onnx_graph_secs": split.graph_secs,
        "onnx_io_secs": split.step_secs - split.graph_secs,
        "onnx_rest_secs": onnx_secs - split.step_secs,
        "onnx_batched_steps": split.steps,
        "onnx_graph_runs": split.runs,
        "onnx_encoder_runs": split.encoder_runs,
        "rounds": args.rounds,
        "threads": 1,
    });
    println!("{line}");
    Ok(ExitStatus::Success)
}
