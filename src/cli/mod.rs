//! Command-line arguments (clap) and dispatch to the library.

mod bench;
mod env_cmd;
mod eval;
mod faithfulness;
mod policy_cmd;
mod replay;
mod run_dir;
mod train;
mod train_start;
mod validate;
mod view;

use clap::{Parser, Subcommand};

use crate::ExitStatus;

/// Make language-conditioned RL agents transparent: a BabyAI world, a per-word text-visual
/// attention policy, PPO, grounding metrics, recordings and a debugger.
#[derive(Debug, Parser)]
#[command(
    name = "groundscope",
    version,
    after_long_help = "EXIT STATUS:\n  0  done\n  1  ran, but a check failed (a replay mismatch, a metric below its threshold)\n  2  error or bad input (one line on stderr naming the file, field or word)"
)]
pub struct Cli {
    /// What to do; without a subcommand, `view` opens the debugger.
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Open the interactive debugger (the default without a subcommand).
    View(Box<view::ViewArgs>),
    /// Inspect and check the world: `env show`, `env verify`.
    #[command(subcommand)]
    Env(env_cmd::EnvCommand),
    /// Write a freshly, deterministically initialised checkpoint.
    Init(policy_cmd::InitArgs),
    /// Run a checkpoint on episodes and show what it saw and attended to: a JSON trace, Rerun
    /// (`--save`, `--spawn`, `--connect`) and MCAP.
    Replay(replay::ReplayArgs),
    /// Evaluate checkpoints over room sizes × object counts: performance, grounding accuracies,
    /// reports and figures.
    Eval(Box<eval::EvalArgs>),
    /// Test whether the attention explains the behaviour: occlusion, deletion/insertion,
    /// interventions on M, closed-loop re-runs, counterfactual worlds, localisation; each
    /// beside its control.
    Faithfulness(Box<faithfulness::FaithfulnessArgs>),
    /// Train a policy with recurrent PPO.
    Train(Box<train::TrainArgs>),
    /// Evaluate saved checkpoints on the held-out validation levels that `train` tracks
    /// (`eval_log.csv` rows): to compare checkpoints without the test set of `eval`.
    Validate(validate::ValidateArgs),
    /// Plot training curves (mean reward against frames, the paper's Fig. 4) from log.csv files
    /// (a run directory's `log.csv`, or a bundled `NAME_log.csv`); runs whose names differ only
    /// in a seed suffix (`-s2`, `_seed3`) are drawn as one mean ± std band. Where the tracked
    /// evaluation sits beside a log (`eval_log.csv`, or `NAME_eval_log.csv`),
    /// OUT_grounding.png shows grounding emerge (held-out greedy success and acc_ng against
    /// frames).
    #[command(
        after_long_help = "EXAMPLES:\n  groundscope curve runs/attention/log.csv runs/baseline/log.csv --out fig4.png\n  groundscope curve runs/att-s1/log.csv runs/att-s2/log.csv runs/att-s3/log.csv --out att.png"
    )]
    Curve {
        /// Training logs; each line's label is its run directory's name.
        #[arg(required = true, value_name = "LOG.csv")]
        logs: Vec<std::path::PathBuf>,
        /// Output PNG.
        #[arg(long, value_name = "FILE")]
        out: std::path::PathBuf,
    },
    /// Speed benchmarks that print JSON lines.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

/// Runs the parsed command.
pub fn run(cli: Cli, matches: &clap::ArgMatches) -> anyhow::Result<ExitStatus> {
    match cli.command.unwrap_or_else(|| Command::View(Box::default())) {
        Command::View(args) => view::run(&args),
        Command::Env(cmd) => env_cmd::run(cmd),
        Command::Bench(cmd) => bench::run(&cmd),
        Command::Train(args) => train::run(&args, matches.subcommand_matches("train")),
        Command::Eval(args) => eval::run(&args),
        Command::Validate(args) => validate::run(&args),
        Command::Faithfulness(args) => faithfulness::run(&args),
        Command::Curve { logs, out } => curve(&logs, &out),
        Command::Init(args) => policy_cmd::init(&args),
        Command::Replay(args) => replay::replay(&args),
    }
}

fn curve(logs: &[std::path::PathBuf], out: &std::path::Path) -> anyhow::Result<ExitStatus> {
    use groundscope::metrics::bands::{band, band_panels, read_columns, recipe_of, run_files};
    use groundscope::metrics::figures::{Curve, learning_curve, read_training_log};
    check_extension(out, "png", "--out")?;
    // Runs of one recipe (names differing only in a seed suffix) become one band.
    let mut groups: Vec<(String, Vec<std::path::PathBuf>)> = Vec::new();
    // A glob such as `assets/runs/*_log.csv` also matches the tracked evaluations; those are
    // read beside their logs, not drawn as logs.
    let logs: Vec<&std::path::PathBuf> = logs
        .iter()
        .filter(|p| !p.to_string_lossy().ends_with("eval_log.csv"))
        .collect();
    if logs.is_empty() {
        anyhow::bail!("no training log among the files (only eval_log.csv files were given)");
    }
    for log in logs {
        let recipe = recipe_of(&run_files(log).0);
        match groups.iter_mut().find(|g| g.0 == recipe) {
            Some(g) => g.1.push(log.clone()),
            None => groups.push((recipe, vec![log.clone()])),
        }
    }
    if groups.iter().all(|g| g.1.len() == 1) {
        let mut curves = Vec::new();
        for (label, paths) in &groups {
            curves.push(Curve {
                label: label.clone(),
                points: read_training_log(&paths[0])?,
            });
        }
        learning_curve(&curves, "Mean reward during training", out)?;
    } else {
        let mut bands = Vec::new();
        for (label, paths) in &groups {
            let runs = paths
                .iter()
                .map(|p| read_training_log(p))
                .collect::<Result<Vec<_>, _>>()?;
            bands.push(band(&format!("{label} (n={})", paths.len()), &runs, 100));
        }
        band_panels(
            &[("mean training reward".into(), bands)],
            "Mean reward during training (mean ± std over seeds)",
            out,
        )?;
    }
    println!("wrote {}", out.display());
    // Grounding emergence, from the tracked evaluations beside the logs.
    let metrics = [
        ("greedy_success", "greedy success (held-out)"),
        ("object_acc_ng", "object-word acc_ng"),
        ("color_acc_ng", "colour-word acc_ng"),
        ("combined_acc_ng", "M on targets, acc_ng"),
    ];
    let mut panels: Vec<(String, Vec<groundscope::metrics::bands::Band>)> = metrics
        .iter()
        .map(|m| (m.1.to_owned(), Vec::new()))
        .collect();
    let mut any = false;
    for (label, paths) in &groups {
        let evals: Vec<std::path::PathBuf> = paths
            .iter()
            .map(|p| run_files(p).1)
            .filter(|p| p.exists())
            .collect();
        if evals.is_empty() {
            continue;
        }
        any = true;
        let mut names = vec!["frames"];
        names.extend(metrics.iter().map(|m| m.0));
        let tables = evals
            .iter()
            .map(|p| read_columns(p, &names))
            .collect::<Result<Vec<_>, _>>()?;
        for (k, panel) in panels.iter_mut().enumerate() {
            let runs: Vec<Vec<(f64, f64)>> = tables
                .iter()
                .map(|rows| rows.iter().map(|r| (r[0], r[k + 1])).collect())
                .collect();
            panel
                .1
                .push(band(&format!("{label} (n={})", evals.len()), &runs, 50));
        }
    }
    if any {
        let stem = out.with_extension("");
        let g = std::path::PathBuf::from(format!("{}_grounding.png", stem.display()));
        band_panels(
            &panels,
            "Grounding emergence (tracked held-out evaluation)",
            &g,
        )?;
        println!("wrote {}", g.display());
    }
    Ok(ExitStatus::Success)
}

/// Fails unless `path` ends in `.ext`, naming the flag.
pub(crate) fn check_extension(path: &std::path::Path, ext: &str, flag: &str) -> anyhow::Result<()> {
    if path.extension().and_then(|e| e.to_str()) == Some(ext) {
        Ok(())
    } else {
        anyhow::bail!(
            "{flag} {}: the file name must end in .{ext}",
            path.display()
        )
    }
}
