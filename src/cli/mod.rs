//! Command-line arguments (clap) and dispatch to the library.

mod bench;
mod bench_bot;
mod bench_levels;
#[cfg(feature = "onnx")]
mod bench_onnx;
mod bench_record;
mod bench_sweep;
mod bench_view;
mod curve;
mod default_model;
mod env_cmd;
mod eval;
mod eval_episodes;
mod faithfulness;
mod flags;
mod model_options;
mod policy_cmd;
mod replay;
mod stop;
mod study;
mod study_exec;
mod study_legacy;
mod study_plan;
mod study_run;
mod study_steps;
mod train;
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
    after_long_help = "EXIT STATUS:\n  0  done\n  1  ran, but a check failed (a replay mismatch, a metric below its threshold)\n  2  error or bad input (one line on stderr naming the file, field or word)\n  130  stopped by Ctrl-C (SIGTERM, SIGHUP) before it finished, one line on stderr: eval and faithfulness write nothing; train saves, and its run is not finished until a --resume reaches --frames; study exec and study run leave the run to resume"
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
    /// The world: `env list` (the 96 BabyAI levels), `env show`, `env verify`.
    #[command(subcommand)]
    Env(env_cmd::EnvCommand),
    /// Write a freshly, deterministically initialised checkpoint.
    Init(policy_cmd::InitArgs),
    /// Run a checkpoint on episodes and show what it saw and attended to: a JSON trace, Rerun
    /// (`--save`, `--spawn`, `--connect`) and MCAP.
    Replay(replay::ReplayArgs),
    /// Evaluate checkpoints over room sizes × object counts, or over BabyAI levels (`--levels`):
    /// performance, grounding accuracies, reports and figures.
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
    /// OUT_grounding.png shows grounding emerge (held-out greedy success and the word maps'
    /// accuracy, acc_ng or acc, against frames).
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
        /// The accuracy drawn in the grounding figure: acc-ng (the map passes τ in the object's
        /// 3×3 neighbourhood) or acc (on the object's own cell, the targets).
        #[arg(long, value_enum, default_value = "acc-ng")]
        accuracy: curve::Accuracy,
    },
    /// Studies: seeds × recipes × levels planned into typed runs (one `study exec` line
    /// each), run here N at a time, on Slurm or on Ray, and collected into one report
    /// (docs/studies.md).
    #[command(subcommand)]
    Study(study::StudyCommand),
    /// Speed benchmarks that print JSON lines.
    #[command(
        subcommand,
        after_long_help = "EXAMPLES:\n  groundscope bench env --steps 1000000\n  groundscope bench policy --model baseline --secs 2\n  groundscope bench train --frames 20480\n  groundscope bench onnx --checkpoint tests/fixtures/onnx/bundled_attention.onnx --rounds 1"
    )]
    Bench(bench::BenchCommand),
}

/// Runs the parsed command.
pub fn run(cli: Cli, matches: &clap::ArgMatches) -> anyhow::Result<ExitStatus> {
    say_renamed_checkpoints();
    match cli.command.unwrap_or_else(|| Command::View(Box::default())) {
        Command::View(args) => view::run(&args),
        Command::Env(cmd) => env_cmd::run(cmd),
        Command::Bench(cmd) => bench::run(&cmd),
        Command::Train(args) => train::run(&args, matches.subcommand_matches("train")),
        Command::Eval(args) => eval::run(&args),
        Command::Validate(args) => validate::run(&args),
        Command::Faithfulness(args) => faithfulness::run(&args),
        Command::Curve {
            logs,
            out,
            accuracy,
        } => curve::curve(&logs, &out, accuracy),
        Command::Init(args) => policy_cmd::init(&args),
        Command::Replay(args) => replay::replay(&args),
        Command::Study(cmd) => study::run(&cmd),
    }
}

/// Says what an old bundled name on the command line opens now (`bundled:babyai-grounded2` is
/// `bundled:babyai`), once per name; a removed one is refused where it is loaded.
fn say_renamed_checkpoints() {
    use groundscope::policy::bundled::{Alias, alias};
    let mut said = Vec::new();
    for arg in std::env::args().skip(1) {
        let value = arg.split_once('=').map_or(arg.as_str(), |(_, v)| v);
        for spec in value.split(',') {
            if let Some(renamed @ Alias::Renamed { .. }) = alias(spec)
                && !said.contains(&spec.to_owned())
            {
                eprintln!("note: {spec}: {renamed}");
                said.push(spec.to_owned());
            }
        }
    }
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

/// Fails when two of a command's outputs (each its flag and path; those not given left out)
/// name the same file, naming both flags: one would overwrite the other, and the command
/// would say it wrote both.
pub(crate) fn check_distinct_outputs(outputs: &[(&str, &std::path::Path)]) -> anyhow::Result<()> {
    match groundscope::files::same_output(outputs) {
        Some(((a, pa), (b, pb))) => anyhow::bail!(
            "{a} {} and {b} {} name the same file: give each output its own path",
            pa.display(),
            pb.display()
        ),
        None => Ok(()),
    }
}
