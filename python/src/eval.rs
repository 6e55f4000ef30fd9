//! `groundscope.evaluate` and `groundscope.record` for a Python policy: the core's sweep,
//! metrics, report writer and recorders, with [`PyPolicy`] in place of a checkpoint. The
//! report directory holds what `groundscope eval` writes (report.md/json, episodes.csv, the
//! CSV tables, figures); the recording what `groundscope replay --save / --mcap` writes.

use std::path::PathBuf;
use std::time::Instant;

use groundscope::env::seeds::{EPISODES_PER_EVAL_SEED, MAX_EVAL_SEEDS, eval_level_seed};
use groundscope::episode::{ActionMode, EpisodeSpec, initial_world, run_from};
use groundscope::metrics::assemble::cell_from_episodes;
use groundscope::metrics::report::{
    CheckpointInfo, Report, SCHEMA_VERSION, episodes_csv, worst_episodes,
};
use groundscope::metrics::sweep::{EvalOptions, evaluate_episodes_explored};
use groundscope::policy::PolicyError;
use groundscope::record::{RerunTargets, record_rerun, write_mcap};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use crate::env::{opt_u64_arg, opt_usize_arg, parse_level, u64_arg};
use crate::policy::{MapLayout, PyPolicy};

/// The most episodes one level may run at once (rows are carried as f32 indices).
const MAX_BATCH: u64 = 1 << 24;

/// The Python exception for a failed run: the callable's own exception where it raised one
/// (or its output was refused), else the core's error.
fn run_error(policy: &PyPolicy<'_>, e: &dyn std::fmt::Display) -> PyErr {
    policy
        .take_error()
        .unwrap_or_else(|| PyRuntimeError::new_err(e.to_string()))
}

fn mode(sample: bool) -> ActionMode {
    if sample {
        ActionMode::Sampled
    } else {
        ActionMode::Greedy
    }
}

fn check_alpha(alpha: f64) -> PyResult<()> {
    if (0.0..=1.0).contains(&alpha) {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "alpha {alpha} is outside [0, 1]"
        )))
    }
}

/// Runs `act` on `episodes` episodes of each evaluation seed `first_seed ..
/// first_seed + seeds` of every level (level seeds `s·10⁶ + e`, as `groundscope eval`) and
/// writes the report to `out`. Returns report.json's content.
#[pyfunction]
#[pyo3(signature = (act, levels, seeds=None, episodes=None, out=PathBuf::from("run"), first_seed=None, sample=false, alpha=0.5, name="python".to_owned(), map_layout="image", top_k=None))]
#[expect(
    clippy::too_many_arguments,
    reason = "the keyword arguments of the Python function"
)]
pub fn evaluate(
    py: Python<'_>,
    act: Bound<'_, PyAny>,
    levels: Vec<String>,
    seeds: Option<Bound<'_, PyAny>>,
    episodes: Option<Bound<'_, PyAny>>,
    out: PathBuf,
    first_seed: Option<Bound<'_, PyAny>>,
    sample: bool,
    alpha: f64,
    name: String,
    map_layout: &str,
    top_k: Option<Bound<'_, PyAny>>,
) -> PyResult<String> {
    // Each int named when it is out of range (PyO3's own conversion raised an OverflowError
    // naming none); left out, the signature's defaults of `groundscope.evaluate`.
    let seeds = opt_u64_arg(seeds.as_ref(), "seeds")?.unwrap_or(5);
    let episodes = opt_u64_arg(episodes.as_ref(), "episodes")?.unwrap_or(100);
    let first_seed = opt_u64_arg(first_seed.as_ref(), "first_seed")?.unwrap_or(0);
    let top_k = opt_usize_arg(top_k.as_ref(), "top_k")?.unwrap_or(10);
    let layout = MapLayout::parse(map_layout)?;
    check_alpha(alpha)?;
    if levels.is_empty() {
        return Err(PyValueError::new_err("levels: give at least one level id"));
    }
    if seeds == 0 || episodes == 0 {
        return Err(PyValueError::new_err(format!(
            "seeds and episodes must be at least 1, got seeds={seeds} episodes={episodes}"
        )));
    }
    if episodes >= EPISODES_PER_EVAL_SEED {
        return Err(PyValueError::new_err(format!(
            "episodes={episodes} must be below 1000000 (level seeds are seed·10⁶ + episode)"
        )));
    }
    if first_seed
        .checked_add(seeds)
        .is_none_or(|end| end > MAX_EVAL_SEEDS)
    {
        return Err(PyValueError::new_err(format!(
            "first_seed={first_seed} seeds={seeds} reaches past evaluation seed {}",
            MAX_EVAL_SEEDS - 1
        )));
    }
    if seeds * episodes > MAX_BATCH {
        return Err(PyValueError::new_err(format!(
            "seeds × episodes = {} is above {MAX_BATCH} episodes per level",
            seeds * episodes
        )));
    }
    // Every level is checked before anything runs: no partial report.
    let levels = levels
        .iter()
        .map(|id| parse_level(id))
        .collect::<PyResult<Vec<_>>>()?;
    let policy = PyPolicy::new(act, layout)?;
    let opts = EvalOptions {
        alpha,
        mode: mode(sample),
        saliency: false,
    };
    let start = Instant::now();
    let mut explored_cells = Vec::new();
    for level in &levels {
        let plan: Vec<(u64, u64)> = (first_seed..first_seed + seeds)
            .flat_map(|s| (0..episodes).map(move |e| (s, eval_level_seed(s, e))))
            .collect();
        let missions = plan
            .iter()
            .map(|&(_, seed)| level.generate(seed).map(|w| w.mission))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        policy.begin(missions);
        let explored = evaluate_episodes_explored(&policy, level, &plan, &opts, &mut |_| {})
            .map_err(|e| run_error(&policy, &e))?;
        explored_cells.push((*level, explored));
        // Ctrl-C in the notebook or terminal stops between levels.
        py.check_signals()?;
    }
    let variant = policy.variant_seen();
    let mut cells = Vec::new();
    let mut all_eps = Vec::new();
    for (config, explored) in explored_cells {
        let (cell, eps) = cell_from_episodes(&name, variant, &config, explored, false);
        cells.push(cell);
        all_eps.push((name.clone(), config, eps));
    }
    let report = Report {
        schema_version: SCHEMA_VERSION,
        groundscope_version: env!("CARGO_PKG_VERSION").into(),
        alpha,
        mode: opts.mode.name().into(),
        seeds,
        first_seed,
        episodes_per_seed: episodes,
        saliency: false,
        checkpoints: vec![CheckpointInfo {
            name: name.clone(),
            variant: variant.name().into(),
            // A Python policy's training is its own: not known here.
            frames: None,
            level: None,
            model_name: None,
            training: None,
            ground_loss: None,
            python: true,
        }],
        cells,
        elapsed_secs: start.elapsed().as_secs_f64(),
    };
    let sample_arg = if sample { ", sample=True" } else { "" };
    let failures = worst_episodes(&all_eps, top_k, &|_, level, seed| {
        let id = level.id();
        format!("groundscope.record(act, \"{id}\", {seed}, \"{id}-seed{seed}.rrd\"{sample_arg})")
    });
    report
        .write(&out, &failures, &episodes_csv(&all_eps))
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    serde_json::to_string(&report).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// Runs `act` on one episode of `level` from level seed `seed` and writes it to `path`: a
/// Rerun recording (`.rrd`) or MCAP (`.mcap`), as `groundscope replay` writes them. Returns
/// `(success, steps, reward)`.
#[pyfunction]
#[pyo3(signature = (act, level, seed, path, sample=false, alpha=0.5, name="python".to_owned(), map_layout="image"))]
#[expect(
    clippy::too_many_arguments,
    reason = "the keyword arguments of the Python function"
)]
pub fn record(
    act: Bound<'_, PyAny>,
    level: &str,
    seed: Bound<'_, PyAny>,
    path: PathBuf,
    sample: bool,
    alpha: f64,
    name: String,
    map_layout: &str,
) -> PyResult<(bool, usize, f64)> {
    let seed = u64_arg(&seed, "seed")?;
    let layout = MapLayout::parse(map_layout)?;
    check_alpha(alpha)?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let rrd = match ext.as_deref() {
        Some("rrd") => true,
        Some("mcap") => false,
        _ => {
            return Err(PyValueError::new_err(format!(
                "path {} must end in .rrd (Rerun) or .mcap",
                path.display()
            )));
        }
    };
    let level = parse_level(level)?;
    let policy = PyPolicy::new(act, layout)?;
    let spec = EpisodeSpec {
        level,
        seed,
        mission: None,
        mode: mode(sample),
    };
    let world = initial_world(&spec).map_err(|e| PyValueError::new_err(e.to_string()))?;
    policy.begin(vec![world.mission.clone()]);
    let trace =
        run_from(&policy, &name, &spec, world).map_err(|e: PolicyError| run_error(&policy, &e))?;
    let summary = (trace.success(), trace.steps.len(), trace.total_reward());
    let episodes = [trace];
    if rrd {
        let targets = RerunTargets {
            save: Some(path),
            ..RerunTargets::default()
        };
        record_rerun(&episodes, &targets, alpha, None).map(|_| ())
    } else {
        write_mcap(&episodes, &path, alpha, None).map(|_| ())
    }
    .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(summary)
}
