//! `groundscope bench sweep`: the default evaluation sweep as a user runs it
//! (`groundscope eval --out DIR`, every measure it computes), in a process of its own, timed
//! as a whole and split into its episodes and the rest (the worst episodes' re-runs, the
//! tables, the figures and the report), as one JSON line.

use std::process::{Command, Stdio};
use std::time::Instant;

use anyhow::Context as _;
use clap::Args;

use crate::ExitStatus;

/// `groundscope bench sweep`.
#[derive(Debug, Args)]
pub struct BenchSweepArgs {
    /// Evaluation seeds per cell [default: eval's, 5].
    #[arg(long, allow_negative_numbers = true)]
    pub seeds: Option<u64>,
    /// Episodes per seed [default: eval's, 100].
    #[arg(long, allow_negative_numbers = true)]
    pub episodes: Option<u64>,
    /// Worker threads [default: eval's, one per core].
    #[arg(long, allow_negative_numbers = true)]
    pub jobs: Option<usize>,
}

/// Runs the sweep and prints its JSON line.
pub(super) fn run(args: &BenchSweepArgs) -> anyhow::Result<ExitStatus> {
    for (flag, v) in [("--seeds", args.seeds), ("--episodes", args.episodes)] {
        if v == Some(0) {
            anyhow::bail!("{flag} 0: must be at least 1");
        }
    }
    if args.jobs == Some(0) {
        anyhow::bail!("--jobs 0: must be at least 1");
    }
    let dir = tempfile::tempdir().context("a temporary directory for the report")?;
    let out = dir.path().join("report");
    let exe = std::env::current_exe().context("finding groundscope's own executable")?;
    let mut cmd = Command::new(exe);
    cmd.arg("eval").arg("--out").arg(&out).arg("--quiet");
    for (flag, v) in [
        ("--seeds", args.seeds),
        ("--episodes", args.episodes),
        ("--jobs", args.jobs.map(|j| j as u64)),
    ] {
        if let Some(v) = v {
            cmd.arg(flag).arg(v.to_string());
        }
    }
    let start = Instant::now();
    let done = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .context("running groundscope eval")?;
    let total = start.elapsed().as_secs_f64();
    if !done.status.success() {
        anyhow::bail!(
            "groundscope eval failed: {}",
            String::from_utf8_lossy(&done.stderr).trim()
        );
    }
    let path = out.join("report.json");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let report: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("reading {}", path.display()))?;
    let field = |name: &str| {
        report[name]
            .as_f64()
            .with_context(|| format!("{}: no number {name}", path.display()))
    };
    let episodes_secs = field("elapsed_secs")?;
    let cells = report["cells"].as_array().map_or(0, Vec::len) as u64;
    let seeds = field("seeds")? as u64;
    let per_seed = field("episodes_per_seed")? as u64;
    println!(
        "{}",
        serde_json::json!({
            "bench": "sweep",
            "cells": cells,
            "episodes": cells * seeds * per_seed,
            "total_secs": total,
            "episodes_secs": episodes_secs,
            "rest_secs": (total - episodes_secs).max(0.0),
        })
    );
    Ok(ExitStatus::Success)
}
