//! `groundscope faithfulness`: does the attention explain the behaviour? Occlusion,
//! deletion/insertion, interventions on `M`, closed-loop re-runs, counterfactual worlds and
//! localisation, each beside its control; see docs/faithfulness.md.

use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, ValueEnum};
use groundscope::metrics::faithfulness::report::{
    CheckpointFaithfulness, FaithfulnessReport, REPORT_FILE, SCHEMA_VERSION, steps_csv,
};
use groundscope::metrics::faithfulness::{self, EpisodeResult, Parts, figures, summarise};
use groundscope::metrics::sweep::eval_level_seed;
use groundscope::policy::{Agent, bundled};

use super::flags::SweepArgs;
use super::stop::Stop;
use crate::ExitStatus;

/// The parts of the analysis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Part {
    /// Per step: occlusion, deletion/insertion, one-step interventions, localisation.
    Steps,
    /// Whole episodes with an intervention at every step: on M for a model that takes
    /// interventions (a native attention checkpoint, a graph with the override inputs), on
    /// the input (the most salient or a random object occluded) for any other.
    ClosedLoop,
    /// Counterfactual worlds edited at the start (every model; tracking of M needs maps).
    Counterfactuals,
}

/// The help of `faithfulness --episodes`: per seed, and the total a run adds up to.
pub const EPISODES_HELP: &str = "Episodes per evaluation seed: each checkpoint and level runs --seeds × --episodes episodes (the defaults, 5 × 100 = 500; `--seeds 1 --episodes N` runs N). faithfulness.md states the total";

/// `groundscope faithfulness`.
#[derive(Debug, Args)]
#[command(after_long_help = "EXAMPLES:\n  \
    groundscope faithfulness --out faith\n  \
    groundscope faithfulness --checkpoint runs/att/model --sizes 10 --objects 6 --out faith10\n  \
    groundscope faithfulness --checkpoint bundled:baseline --out faith-baseline\n  \
    groundscope faithfulness --checkpoint my_agent.onnx --out faith-onnx",
    // One cell by default: the paper's training level.
    mut_arg("sizes", |a| a.default_value("8")),
    mut_arg("objects", |a| a.default_value("4")),
    // Episodes are per evaluation seed: say what a run adds up to (`--episodes 10` with the
    // default 5 seeds runs 50 episodes per checkpoint and level, and faithfulness.md says so).
    mut_arg("episodes", |a| a.help(EPISODES_HELP).long_help(EPISODES_HELP)))]
pub struct FaithfulnessArgs {
    /// Checkpoints (repeatable): NAME, a run directory (its model), bundled:NAME or an ONNX
    /// graph FILE.onnx (docs/onnx.md) [default: bundled:attention; bundled:minigrid on
    /// MiniGrid's own ids]; not `bot`, which has no network to probe.
    #[arg(long, value_name = "NAME")]
    pub checkpoint: Vec<String>,
    /// Output directory.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// Parts to compute [default: all three].
    #[arg(long, value_delimiter = ',', value_enum)]
    pub parts: Vec<Part>,
    /// Worker threads [default: the number of cores].
    #[arg(long, allow_negative_numbers = true)]
    pub jobs: Option<usize>,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Refuses flags that no faithfulness run can run with, reading no file: the sweep (its
/// counts and seeds, its `--levels` ids, its rooms) and the workers. `faithfulness` checks
/// them first, and `study plan` checks each run's faithfulness step with them.
pub fn validate(args: &FaithfulnessArgs) -> anyhow::Result<()> {
    args.sweep.check()?;
    args.sweep.check_levels()?;
    if args.jobs == Some(0) {
        anyhow::bail!("--jobs 0: give at least one worker");
    }
    Ok(())
}

/// Runs `faithfulness`.
pub fn run(args: &FaithfulnessArgs) -> anyhow::Result<ExitStatus> {
    run_with(args, &Stop::install())
}

/// Runs `faithfulness`, stopped by `stop` (a study's exec hands its own on: a process has one).
pub(super) fn run_with(args: &FaithfulnessArgs, stop: &Stop) -> anyhow::Result<ExitStatus> {
    validate(args)?;
    let specs = if args.checkpoint.is_empty() {
        let paper = Agent::load(&bundled::names()[0])?;
        let levels = args.sweep.levels(paper.level())?;
        vec![super::default_model::for_faithfulness(&levels)]
    } else {
        args.checkpoint.clone()
    };
    let mut cells = Vec::new();
    for spec in &specs {
        let agent = std::sync::Arc::new(Agent::load(spec)?);
        if agent.acting().reads_world() {
            anyhow::bail!(
                "--checkpoint {spec}: faithfulness probes a network's dependence on its inputs; minigrid's bot has no network (it acts from the world)"
            );
        }
        let interventions = agent.acting().takes_interventions();
        let parts = if args.parts.is_empty() {
            Parts {
                steps: true,
                closed_loop: true,
                counterfactuals: true,
                interventions,
            }
        } else {
            let wants = |p| args.parts.contains(&p);
            Parts {
                steps: wants(Part::Steps),
                closed_loop: wants(Part::ClosedLoop),
                counterfactuals: wants(Part::Counterfactuals),
                interventions,
            }
        };
        for level in args.sweep.levels(agent.level())? {
            cells.push((spec.clone(), agent.clone(), level, parts));
        }
    }
    // Fail on an unwritable directory before the work, and write nothing partial after it.
    let staging =
        groundscope::files::StagedDir::new(&args.out).map_err(|e| anyhow::anyhow!("--out {e}"))?;
    let mode = args.sweep.mode();
    let episodes = args.sweep.episodes;
    let plan: Vec<(u64, u64)> = args
        .sweep
        .seed_range()
        .flat_map(|s| (0..episodes).map(move |e| (s, eval_level_seed(s, e))))
        .collect();
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new((plan.len() * cells.len()) as u64)
    };
    let start = Instant::now();
    let mut entries: Vec<CheckpointFaithfulness> = Vec::new();
    let mut all: Vec<(String, Vec<EpisodeResult>)> = Vec::new();
    for (i, (name, agent, level, parts)) in cells.iter().enumerate() {
        let offset = (i * plan.len()) as u64;
        let acting = agent.acting();
        let eps = faithfulness::run(
            &stop.guard(acting),
            level,
            &plan,
            mode,
            *parts,
            jobs,
            &|done| bar.set_position(offset + done as u64),
        );
        if stop.requested() {
            // Dropping the staged directory removes it (and --out, when this run made it).
            drop(staging);
            bar.finish_and_clear();
            Stop::report(&args.out);
            return Ok(ExitStatus::Interrupted);
        }
        let eps = eps?;
        let mut entry = summarise(name, acting.variant().name(), &eps);
        entry.level = level.to_string();
        entries.push(entry);
        all.push((format!("{name} {level}"), eps));
    }
    bar.finish_and_clear();
    let report = FaithfulnessReport {
        schema_version: SCHEMA_VERSION,
        level: cells
            .iter()
            .map(|c| c.2.to_string())
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect::<Vec<_>>()
            .join(", "),
        seeds: args.sweep.seeds,
        first_seed: args.sweep.first_seed,
        episodes_per_seed: args.sweep.episodes,
        actions: mode.name(),
        seconds: start.elapsed().as_secs_f64(),
        checkpoints: entries,
    };
    staging.write(
        REPORT_FILE,
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    staging.write("faithfulness.md", report.markdown().as_bytes())?;
    let rows: Vec<(String, &[EpisodeResult])> =
        all.iter().map(|(n, e)| (n.clone(), e.as_slice())).collect();
    staging.write("faithfulness_steps.csv", steps_csv(&rows).as_bytes())?;
    // The figures faithfulness.md links, each drawn once.
    for (i, c) in report.checkpoints.iter().enumerate() {
        for (stem, _, file) in report.figure_files(i) {
            let path = staging.path(&file);
            match stem {
                "deletion" => figures::deletion_curves(c, &path)?,
                "rank_correlation" => figures::rho_distribution(c, &path)?,
                _ => figures::effects(c, &path)?,
            }
        }
    }
    // A reused directory keeps no figure of an earlier run's other checkpoints (`*_1.png`).
    let written = staging.commit_owned(|name| {
        name.starts_with("faithfulness")
            || (std::path::Path::new(name)
                .extension()
                .is_some_and(|e| e == "png")
                && ["deletion", "rank_correlation", "effects"]
                    .iter()
                    .any(|p| name.starts_with(p)))
    })?;
    print!("{}", report.markdown());
    println!("wrote {} files to {}", written, args.out.display());
    Ok(ExitStatus::Success)
}
