//! `groundscope eval`: the paper's evaluation sweep, grounding accuracies and reports.

use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::Context as _;
use clap::Args;
use groundscope::env::LevelConfig;
use groundscope::episode::{ActionMode, EpisodeSpec};
use groundscope::metrics::assemble::cell_from_episodes;
use groundscope::metrics::exploration::EpisodeExploration;
use groundscope::metrics::failure::counterfactual;
use groundscope::metrics::report::{
    CheckpointInfo, Report, SCHEMA_VERSION, episodes_csv, worst_episodes,
};
use groundscope::metrics::sweep::{EpisodeSummary, EvalOptions, evaluate_cell_explored};
use groundscope::policy::Agent;

use super::flags::SweepArgs;
use super::stop::Stop;
use crate::ExitStatus;

/// `groundscope eval`.
#[derive(Debug, Args)]
#[command(
    after_long_help = "EXAMPLES:\n  groundscope eval --out report/\n  groundscope eval --checkpoint runs/att/model --sizes 8,10 --objects 4,6 --seeds 2 --episodes 50 --out quick/ --min-success 0.9\n  groundscope eval --checkpoint my_agent.onnx --saliency --out mine/\n  groundscope eval --checkpoint bundled:babyai --levels BabyAI-GoToDoor-v0,BabyAI-PickupLoc-v0 --seeds 1 --out levels/\n  groundscope eval --checkpoint runs/mg --levels MiniGrid-DoorKey-5x5-v0,\"MultiRoomEnv(minNumRooms=3, maxNumRooms=3)\" --out minigrid/"
)]
pub struct EvalArgs {
    /// Checkpoints to evaluate (repeatable): NAME, a run directory (its model),
    /// bundled:attention / bundled:baseline / bundled:babyai[-grounded[2]], an ONNX graph FILE.onnx or
    /// `bot` (minigrid's BabyAI bot) [default: both bundled ones].
    #[arg(long, value_name = "NAME")]
    pub checkpoint: Vec<String>,
    /// Report directory: report.json, report.md, CSVs, PNG figures, failures.json.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Threshold factor α of the grounding accuracies (τ = α / n).
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub alpha: f64,
    /// For a model without attention maps (a baseline, an ONNX graph that exports none): let
    /// the occlusion saliency stand in for M in the failure classes, so `grounding` is decided
    /// for it too (docs/evaluation.md#failure-classes). Slower: one forward of the perturbed
    /// views at every step with a target in view.
    #[arg(long)]
    pub saliency: bool,
    /// How many worst episodes of each kind to list.
    #[arg(long, default_value_t = 10, allow_negative_numbers = true)]
    pub top_k: usize,
    /// Exit 1 if any cell's mean success rate is below this.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub min_success: Option<f64>,
    /// Exit 1 if any attention cell's mean object-word acc_ng is below this.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub min_acc_ng: Option<f64>,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Also record each listed failure as a Rerun recording in DIR/failures/.
    #[arg(long)]
    pub export_failures: bool,
    /// Worker threads; each evaluates whole cells (default: one per core).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub jobs: Option<usize>,
}

/// Refuses a sweep that cannot run, before anything is loaded or written.
fn check(args: &EvalArgs) -> anyhow::Result<()> {
    validate(args)?;
    let failures_dir = args.out.join("failures");
    if args.export_failures && failures_dir.exists() && !failures_dir.is_dir() {
        anyhow::bail!(
            "--export-failures: {} is not a directory (the recordings go there)",
            failures_dir.display()
        );
    }
    Ok(())
}

/// Refuses flags that no evaluation can run with, reading no file: the workers, α, the
/// thresholds and the sweep (its counts and seeds, its `--levels` ids, its rooms). `eval`
/// checks them first, and `study plan` checks each run's evaluation with them, so that a
/// value every run refuses is one line at plan time, not a failure after each training.
pub fn validate(args: &EvalArgs) -> anyhow::Result<()> {
    // One rule with `faithfulness --jobs`: zero workers is a mistake, not "as many as cores".
    if args.jobs == Some(0) {
        anyhow::bail!("--jobs 0: give at least one worker");
    }
    if !(0.0..=1.0).contains(&args.alpha) {
        anyhow::bail!("--alpha {:?} is outside [0, 1]", args.alpha);
    }
    args.sweep.check()?;
    args.sweep.check_levels()?;
    for (flag, v) in [
        ("--min-success", args.min_success),
        ("--min-acc-ng", args.min_acc_ng),
    ] {
        if let Some(x) = v
            && !(0.0..=1.0).contains(&x)
        {
            anyhow::bail!("{flag} {x:?} is outside [0, 1]");
        }
    }
    Ok(())
}

/// Runs `eval`.
pub fn run(args: &EvalArgs) -> anyhow::Result<ExitStatus> {
    run_with(args, &Stop::install())
}

/// Runs `eval`, stopped by `stop` (a study's exec hands its own on: a process has one).
pub(super) fn run_with(args: &EvalArgs, stop: &Stop) -> anyhow::Result<ExitStatus> {
    check(args)?;
    let specs = if args.checkpoint.is_empty() {
        let paper = Agent::load(&groundscope::policy::bundled::names()[0])?;
        let levels = args.sweep.levels(paper.level())?;
        let first = groundscope::env::seeds::eval_level_seed(args.sweep.first_seed, 0);
        super::default_model::for_levels(&paper, &levels, first)
    } else {
        args.checkpoint.clone()
    };
    let mut ckpts = Vec::new();
    for s in &specs {
        ckpts.push((s.clone(), Agent::load(s)?));
    }
    // Check every cell's level before running anything: no partial report.
    let mut cells = Vec::new();
    for (name, ckpt) in &ckpts {
        for level in args.sweep.levels(ckpt.level())? {
            cells.push((name.clone(), ckpt, level));
        }
    }
    let mode = args.sweep.mode();
    let total = cells.len() as u64 * args.sweep.seeds * args.sweep.episodes;
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(total)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} episodes {msg} ETA {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let start = Instant::now();
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from))
        .clamp(1, cells.len().max(1));
    // Largest worlds first: they take longest, so the workers finish together. A BabyAI
    // level's size is its rooms' cells, not the checkpoint's room size it carries.
    let cost = |l: &LevelConfig| match l.babyai {
        Some(id) => {
            let r = id.spec().rooms;
            (
                (r.room_size * r.room_size * r.num_cols * r.num_rows) as usize,
                0,
            )
        }
        None => (l.room_size * l.room_size, l.n_objects),
    };
    let mut order: Vec<usize> = (0..cells.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(cost(&cells[i].2)));
    let results = run_cells(&cells, &order, jobs, args, mode, &bar, stop);
    if stop.requested() {
        bar.finish_and_clear();
        Stop::report(&args.out);
        return Ok(ExitStatus::Interrupted);
    }
    let mut results: Vec<_> = results
        .into_iter()
        .map(|slot| slot.into_inner().ok().flatten())
        .collect();
    // The error is the answer, not a cell its worker left unrun.
    if let Some(i) = results.iter().position(|r| matches!(r, Some(Err(_))))
        && let Some(Err(e)) = results.swap_remove(i)
    {
        return Err(e);
    }
    let mut report_cells = Vec::new();
    let mut all_eps = Vec::new();
    for ((name, ckpt, level), slot) in cells.iter().zip(results) {
        let explored = slot.unwrap_or_else(|| Err(anyhow::anyhow!("evaluation stopped early")))?;
        let (cell, eps) = cell_from_episodes(
            name,
            ckpt.acting().variant(),
            level,
            explored,
            args.saliency,
        );
        report_cells.push(cell);
        all_eps.push((name.clone(), *level, eps));
    }
    bar.finish_and_clear();
    let elapsed = start.elapsed().as_secs_f64();
    let report = Report {
        schema_version: SCHEMA_VERSION,
        groundscope_version: env!("CARGO_PKG_VERSION").into(),
        alpha: args.alpha,
        mode: mode.name().into(),
        seeds: args.sweep.seeds,
        first_seed: args.sweep.first_seed,
        episodes_per_seed: args.sweep.episodes,
        saliency: args.saliency,
        checkpoints: ckpts
            .iter()
            .map(|(n, c)| CheckpointInfo {
                name: n.clone(),
                variant: c.kind_name().into(),
                frames: c.frames(),
                level: c.trained_level(),
                model_name: c.acting().model_name(),
                training: groundscope::policy::bundled::training_note(n).map(str::to_owned),
                ground_loss: c.ground_loss(),
                python: false,
            })
            .collect(),
        cells: report_cells,
        elapsed_secs: elapsed,
    };
    let sample = if args.sweep.sample { " --sample" } else { "" };
    let mut failures = worst_episodes(&all_eps, args.top_k, &|ckpt, level, seed| {
        let on = match level.babyai {
            Some(id) => format!("--level {}", id.id()),
            None => format!(
                "--room-size {} --objects {}",
                level.room_size, level.n_objects
            ),
        };
        // The mode the episode ran in, where it is not the level's default.
        let done = match (level.babyai.is_some(), level.done_required) {
            (true, true) => " --done",
            (false, false) => " --no-done",
            _ => "",
        };
        format!("groundscope replay --checkpoint {ckpt} {on}{done} --seed {seed}{sample}")
    });
    let counterfactuals = add_counterfactuals(&mut failures, &ckpts, mode, stop);
    if stop.requested() {
        Stop::report(&args.out);
        return Ok(ExitStatus::Interrupted);
    }
    let skipped = counterfactuals?;
    if skipped > 0 {
        println!(
            "{skipped} failed episode(s) could not be re-run without distractors; report.md says why on each row"
        );
    }
    let failures_dir = args.out.join("failures");
    // The recordings are made first, into a hidden directory of --out, and put in place with
    // the report once both are complete: a recording that fails (or Ctrl-C) leaves --out as
    // it was, the earlier report and its recordings included.
    let recorded = if args.export_failures {
        let staged = groundscope::files::StagedDir::new(&args.out)
            .map_err(|e| anyhow::anyhow!("--out {e}"))?;
        let dir = staged.path("failures");
        std::fs::create_dir(&dir)
            .with_context(|| format!("cannot create a directory in {}", args.out.display()))?;
        let n = export_failures(
            &failures,
            &ckpts,
            &dir,
            &failures_dir,
            mode,
            args.alpha,
            stop,
        );
        if stop.requested() {
            drop(staged);
            Stop::report(&args.out);
            return Ok(ExitStatus::Interrupted);
        }
        Some((staged, n?))
    } else {
        None
    };
    report.write(&args.out, &failures, &episodes_csv(&all_eps))?;
    if let Some((staged, (failed, successes))) = recorded {
        put_failures_in_place(&staged.path("failures"), &failures_dir)?;
        staged.commit().map_err(|e| anyhow::anyhow!("--out {e}"))?;
        println!(
            "recorded {failed} failed episode(s) and {successes} success(es) listed for their low acc_cmb, one recording each, in {}",
            failures_dir.display()
        );
    } else {
        remove_old_failures(&failures_dir)?;
    }
    println!(
        "evaluated {total} episodes in {elapsed:.1} s; report in {}",
        args.out.display()
    );
    let failed_checks = summary(args, &report);
    if failed_checks.is_empty() {
        Ok(ExitStatus::Success)
    } else {
        for f in &failed_checks {
            println!("check failed: {f}");
        }
        Ok(ExitStatus::CheckFailed)
    }
}

/// Cell results, in `cells` order.
type CellResults = Vec<Mutex<Option<anyhow::Result<Vec<(EpisodeSummary, EpisodeExploration)>>>>>;

/// Evaluates `cells` in the given order on `jobs` worker threads.
fn run_cells(
    cells: &[(String, &Agent, LevelConfig)],
    order: &[usize],
    jobs: usize,
    args: &EvalArgs,
    mode: ActionMode,
    bar: &indicatif::ProgressBar,
    stop: &Stop,
) -> CellResults {
    let next = AtomicUsize::new(0);
    let progress = AtomicU64::new(0);
    let results: CellResults = cells.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&i) = order.get(k) else { break };
                    let (name, ckpt, level) = &cells[i];
                    let net = stop.guard(ckpt.acting());
                    bar.set_message(format!("{name} {}", level.id()));
                    let mut last = 0u64;
                    // A panic is this cell's error, not a scope that panics after waiting
                    // for every other worker.
                    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        evaluate_cell_explored(
                            &net,
                            level,
                            args.sweep.seed_range(),
                            args.sweep.episodes,
                            &EvalOptions {
                                alpha: args.alpha,
                                mode,
                                saliency: args.saliency,
                            },
                            &mut |n| {
                                let d = n.saturating_sub(last);
                                last = n;
                                bar.set_position(progress.fetch_add(d, Ordering::Relaxed) + d);
                            },
                        )
                    }))
                    .map_err(|p| {
                        anyhow::anyhow!(
                            "{name} {}: {}",
                            level.id(),
                            super::stop::panic_message(p.as_ref())
                        )
                    })
                    .and_then(|r| r.map_err(anyhow::Error::from));
                    if r.is_err() {
                        // Stop the other workers early; the error is reported below.
                        next.store(order.len(), Ordering::Relaxed);
                    }
                    if let Ok(mut slot) = results[i].lock() {
                        *slot = Some(r);
                    }
                }
            });
        }
    });
    results
}

/// The terminal summary, a line per cell, and the gate's failed checks (`--min-success`,
/// `--min-acc-ng`).
fn summary(args: &EvalArgs, report: &groundscope::metrics::report::Report) -> Vec<String> {
    // Columns as wide as their longest entry (a BabyAI id is up to 34 characters); one seed
    // has no spread, so its cells give the mean alone, as report.md does.
    let spread = args.sweep.seeds != 1;
    let wc = report
        .cells
        .iter()
        .map(|c| c.checkpoint.chars().count())
        .chain([10])
        .max()
        .unwrap_or(10);
    let wl = report
        .cells
        .iter()
        .map(|c| c.label().chars().count())
        .chain([5])
        .max()
        .unwrap_or(5);
    let wv = if spread { 15 } else { 7 };
    println!(
        "{:<wc$}  {:<wl$}  {:>wv$}  {:>wv$}  {:>wv$}",
        "checkpoint", "level", "reward", "success", "obj acc_ng"
    );
    let mut failed_checks = Vec::new();
    for c in &report.cells {
        let acc_ng = c.accuracy.as_ref().map(|a| a.object.acc_ng);
        println!(
            "{:<wc$}  {:<wl$}  {:>wv$}  {:>wv$}  {:>wv$}",
            c.checkpoint,
            c.label(),
            c.reward.shown(spread),
            c.success.shown(spread),
            acc_ng.map_or("–".into(), |a| a.shown(spread))
        );
        if let (Some(min), Some(s)) = (args.min_success, c.success.mean)
            && s < min
        {
            failed_checks.push(format!(
                "success {s:.3} < --min-success {min} ({} {})",
                c.checkpoint,
                c.label()
            ));
        }
        if let (Some(min), Some(a)) = (args.min_acc_ng, acc_ng.and_then(|a| a.mean))
            && a < min
        {
            failed_checks.push(format!(
                "object acc_ng {a:.3} < --min-acc-ng {min} ({} {})",
                c.checkpoint,
                c.label()
            ));
        }
    }
    failed_checks
}

/// Fills in the counterfactual verdict of every listed failed episode: its level seed re-run
/// (same checkpoint, mission and action mode) with the non-target objects removed. One that
/// cannot be built (a level whose instruction no longer resolves once the distractors are
/// gone) is marked on its row and counted, and the others go on: a sweep never loses its
/// report to one episode. Returns how many were skipped.
fn add_counterfactuals(
    failures: &mut [groundscope::metrics::report::Failure],
    ckpts: &[(String, Agent)],
    mode: ActionMode,
    stop: &Stop,
) -> anyhow::Result<usize> {
    let mut skipped = 0;
    for f in failures.iter_mut().filter(|f| f.class.is_some()) {
        let Some((name, ckpt)) = ckpts.iter().find(|(n, _)| *n == f.checkpoint) else {
            continue;
        };
        let spec = EpisodeSpec {
            level: f.level_config(ckpt.level())?,
            seed: f.seed,
            mission: None,
            mode,
        };
        match counterfactual(&stop.guard(ckpt.acting()), name, &spec) {
            Ok(c) => f.counterfactual = Some(c),
            Err(_) if stop.requested() => break,
            Err(e) => {
                f.counterfactual_skipped = Some(e.to_string());
                skipped += 1;
            }
        }
    }
    Ok(skipped)
}

/// Puts this run's recordings (the directory `staged`) in place of an earlier run's at `dir`:
/// the earlier `*.rrd` removed, then the directory renamed into place, or, where `dir` keeps
/// files of the user's own, each recording moved in beside them.
fn put_failures_in_place(staged: &std::path::Path, dir: &std::path::Path) -> anyhow::Result<()> {
    remove_old_failures(dir)?;
    let moved =
        |e: std::io::Error| anyhow::anyhow!("cannot move recordings to {}: {e}", dir.display());
    if !dir.exists() {
        return std::fs::rename(staged, dir).map_err(moved);
    }
    for entry in std::fs::read_dir(staged).map_err(moved)? {
        let entry = entry.map_err(moved)?;
        std::fs::rename(entry.path(), dir.join(entry.file_name())).map_err(moved)?;
    }
    Ok(())
}

/// Removes an earlier run's `failures/` recordings (`*.rrd`), and the directory when nothing
/// else is in it.
fn remove_old_failures(dir: &std::path::Path) -> anyhow::Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if entry.file_type().is_ok_and(|t| t.is_file())
            && path.extension().is_some_and(|e| e == "rrd")
        {
            std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
        }
    }
    // Only an empty directory is removed.
    let _ = std::fs::remove_dir(dir);
    Ok(())
}

/// Replays every failure (the same level, seed and action mode as in the sweep) and records
/// it as `DIR/<kind>-<checkpoint>-S<size>-N<objects>-seed<seed>.rrd`; an error names the
/// recording in `shown`, the directory where it is going.
fn export_failures(
    failures: &[groundscope::metrics::report::Failure],
    ckpts: &[(String, Agent)],
    dir: &std::path::Path,
    shown: &std::path::Path,
    mode: ActionMode,
    alpha: f64,
    stop: &Stop,
) -> anyhow::Result<(usize, usize)> {
    use groundscope::record::{RecordError, RerunTargets, record_rerun};
    let (mut failed, mut successes) = (0, 0);
    // An episode listed twice (a long failure with a low acc_cmb too) is recorded once, under
    // the first kind it is listed for: `failed` comes first.
    let mut seen = std::collections::HashSet::new();
    for f in failures {
        let Some((name, ckpt)) = ckpts.iter().find(|(n, _)| *n == f.checkpoint) else {
            continue;
        };
        let key = (
            &f.checkpoint,
            &f.level,
            f.size,
            f.objects,
            f.seed,
            f.done_required,
        );
        if !seen.insert(key) {
            continue;
        }
        let spec = EpisodeSpec {
            level: f.level_config(ckpt.level())?,
            seed: f.seed,
            mission: None,
            mode,
        };
        let trace = groundscope::episode::run_from(
            &stop.guard(ckpt.acting()),
            name,
            &spec,
            groundscope::episode::initial_world(&spec)?,
        )?;
        // The whole name, so two checkpoints called `model` in different runs do not share
        // file names.
        let short: String = name
            .trim_start_matches("bundled:")
            .trim_start_matches("./")
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let on = f
            .level
            .clone()
            .unwrap_or_else(|| format!("S{}-N{}", f.size, f.objects));
        let file = format!("{}-{short}-{on}-seed{}.rrd", f.kind, f.seed);
        let targets = RerunTargets {
            save: Some(dir.join(&file)),
            ..RerunTargets::default()
        };
        record_rerun(std::slice::from_ref(&trace), &targets, alpha, None).map_err(|e| match e {
            RecordError::Io { reason, .. } => {
                anyhow::anyhow!("cannot write {}: {reason}", shown.join(&file).display())
            }
            e => e.into(),
        })?;
        if trace.success() {
            successes += 1;
        } else {
            failed += 1;
        }
    }
    Ok((failed, successes))
}
