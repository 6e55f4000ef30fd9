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
    CheckpointInfo, EPISODES_DIR, REPORT_HTML, Report, SCHEMA_VERSION, episodes_csv, worst_episodes,
};
use groundscope::metrics::sweep::{EpisodeSummary, EvalOptions, evaluate_cell_explored};
use groundscope::policy::Agent;

use super::eval_episodes::{Outputs, put_failures_in_place, remove_old_failures, run_listed};
use super::flags::SweepArgs;
use super::stop::Stop;
use crate::ExitStatus;

/// `groundscope eval`.
#[derive(Debug, Args)]
#[command(
    after_long_help = "EXAMPLES:\n  groundscope eval --out report/\n  groundscope eval --checkpoint runs/att/model --sizes 8,10 --objects 4,6 --seeds 2 --episodes 50 --out quick/ --min-success 0.9\n  groundscope eval --checkpoint my_agent.onnx --saliency --out mine/\n  groundscope eval --checkpoint bundled:babyai --levels BabyAI-GoToDoor-v0,BabyAI-PickupLoc-v0 --seeds 1 --out levels/\n  groundscope eval --checkpoint runs/mg --levels MiniGrid-DoorKey-5x5-v0,\"MultiRoomEnv(minNumRooms=3, maxNumRooms=3)\" --out minigrid/"
)]
#[expect(
    clippy::struct_excessive_bools,
    reason = "each switch is a flag of its own on the command line"
)]
pub struct EvalArgs {
    /// Checkpoints to evaluate (repeatable): NAME, a run directory (its model),
    /// bundled:attention / bundled:baseline / bundled:babyai / bundled:minigrid[-baseline], an
    /// ONNX graph FILE.onnx or `bot` (minigrid's BabyAI bot) [default: the paper's pair,
    /// bundled:babyai on a BabyAI level the paper's model cannot read, MiniGrid's pair where a
    /// level is one of MiniGrid's own ids].
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
    /// Also write DIR/report.html (report.md with its figures inline) and one self-contained
    /// page per listed worst episode in DIR/episodes/ (as `replay --html` makes it), each
    /// linked from its row.
    #[arg(long)]
    pub html: bool,
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
    let pages_dir = args.out.join(EPISODES_DIR);
    if args.html && pages_dir.exists() && !pages_dir.is_dir() {
        anyhow::bail!(
            "--html: {} is not a directory (the episode pages go there)",
            pages_dir.display()
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
    let report = report_of(args, &ckpts, mode, report_cells, elapsed);
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
    // it was, the earlier report and its recordings included. The pages of --html go with
    // the report itself.
    let staged = if args.export_failures {
        let staged = groundscope::files::StagedDir::new(&args.out)
            .map_err(|e| anyhow::anyhow!("--out {e}"))?;
        std::fs::create_dir(staged.path("failures"))
            .with_context(|| format!("cannot create a directory in {}", args.out.display()))?;
        Some(staged)
    } else {
        None
    };
    let listed = if args.export_failures || args.html {
        let rrd = staged.as_ref().map(|s| s.path("failures"));
        let outputs = Outputs {
            rrd: rrd.as_deref().map(|d| (d, failures_dir.as_path())),
            html: args.html,
        };
        let listed = run_listed(&failures, &ckpts, &outputs, mode, args.alpha, stop);
        if stop.requested() {
            drop(staged);
            Stop::report(&args.out);
            return Ok(ExitStatus::Interrupted);
        }
        Some(listed?)
    } else {
        None
    };
    let pages = listed.as_ref().filter(|_| args.html).map(|l| &l.pages);
    report.write_with_pages(&args.out, &failures, &episodes_csv(&all_eps), pages)?;
    match (staged, &listed) {
        (Some(staged), Some(l)) => {
            put_failures_in_place(&staged.path("failures"), &failures_dir)?;
            staged.commit().map_err(|e| anyhow::anyhow!("--out {e}"))?;
            println!(
                "recorded {} failed episode(s) and {} success(es) listed for their low acc_cmb, one recording each, in {}",
                l.failed,
                l.successes,
                failures_dir.display()
            );
        }
        _ => remove_old_failures(&failures_dir)?,
    }
    if let Some(p) = pages {
        println!(
            "wrote {} and {} episode page(s) in {}",
            args.out.join(REPORT_HTML).display(),
            p.pages.len(),
            args.out.join(EPISODES_DIR).display()
        );
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

/// The report of a sweep of `ckpts` that gave `cells` in `elapsed` seconds.
fn report_of(
    args: &EvalArgs,
    ckpts: &[(String, Agent)],
    mode: ActionMode,
    cells: Vec<groundscope::metrics::report::Cell>,
    elapsed: f64,
) -> Report {
    Report {
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
        cells,
        elapsed_secs: elapsed,
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
