//! A study's steps between their flags and their typed form: the flags of a run's steps
//! parsed by the commands' own clap definitions and checked as each command checks them
//! ([`typed_steps`], what a plan stores), and the typed evaluation and faithfulness steps as
//! the arguments their commands run with ([`eval_args`], [`faithfulness_args`], what an exec
//! runs). Each mapping names every field of both sides, so a flag added to `eval` or
//! `faithfulness` is a compile error here until the study carries it.

use std::path::Path;

use clap::{CommandFactory as _, FromArgMatches as _};
use groundscope::study::{EvalSpec, FaithParts, FaithfulnessSpec, RunSteps, Sweep, one_line};

use super::eval::EvalArgs;
use super::faithfulness::{FaithfulnessArgs, Part};
use super::flags::{DoneArgs, SweepArgs};

/// The typed steps of one run from the arguments of its steps (without the program): each
/// parsed as the command it names and checked as that command checks its flags before it
/// runs, reading no file ([`super::train::recipe`], [`super::eval::validate`],
/// [`super::faithfulness::validate`]). A refusal is one line naming the step and the flag.
pub(super) fn typed_steps(
    train: &[String],
    eval: &[String],
    faithfulness: Option<&[String]>,
) -> Result<RunSteps, String> {
    let (command, matches) = parsed("train", train)?;
    let super::Command::Train(args) = command else {
        return Err("train: not a training".to_owned());
    };
    let train = super::train::recipe(&args, matches.subcommand_matches("train"))
        .map_err(|e| refusal("train", &e))?;
    let (command, _) = parsed("eval", eval)?;
    let super::Command::Eval(args) = command else {
        return Err("eval: not an evaluation".to_owned());
    };
    super::eval::validate(&args).map_err(|e| refusal("eval", &e))?;
    let eval = eval_spec(&args);
    let faithfulness = match faithfulness {
        None => None,
        Some(flags) => {
            let (command, _) = parsed("faithfulness", flags)?;
            let super::Command::Faithfulness(args) = command else {
                return Err("faithfulness: not a faithfulness run".to_owned());
            };
            super::faithfulness::validate(&args).map_err(|e| refusal("faithfulness", &e))?;
            Some(faithfulness_spec(&args))
        }
    };
    Ok(RunSteps {
        train,
        eval,
        faithfulness,
    })
}

/// A step's refusal as one line, naming the step.
fn refusal(step: &str, e: &anyhow::Error) -> String {
    format!("{step}: {}", one_line(&format!("{e:#}")))
}

/// `groundscope CMD ARGS` parsed as the command line is, with its matches (which flags were
/// given); clap's refusal as one line, quoting the flag or value as given, escaped and cut.
fn parsed(cmd: &str, args: &[String]) -> Result<(super::Command, clap::ArgMatches), String> {
    let refused = |e: &clap::Error| {
        let text = e.to_string();
        let first = text.lines().next().unwrap_or_default();
        format!("{cmd}: {}", one_line(first.trim_start_matches("error: ")))
    };
    let argv = ["groundscope", cmd]
        .into_iter()
        .chain(args.iter().map(String::as_str));
    let matches = super::Cli::command()
        .try_get_matches_from(argv)
        .map_err(|e| refused(&e))?;
    let cli = super::Cli::from_arg_matches(&matches).map_err(|e| refused(&e))?;
    let command = cli.command.ok_or_else(|| format!("{cmd}: no command"))?;
    Ok((command, matches))
}

/// The sweep the flags describe.
fn sweep_spec(a: &SweepArgs) -> Sweep {
    let SweepArgs {
        sizes,
        objects,
        seeds,
        first_seed,
        episodes,
        sample,
        levels,
        done,
    } = a;
    Sweep {
        sizes: sizes.clone(),
        objects: objects.clone(),
        seeds: *seeds,
        first_seed: *first_seed,
        episodes: *episodes,
        sample: *sample,
        levels: levels.clone(),
        done: if done.done {
            Some(true)
        } else if done.no_done {
            Some(false)
        } else {
            None
        },
    }
}

/// The flags of `sweep`.
fn sweep_args(s: &Sweep) -> SweepArgs {
    SweepArgs {
        sizes: s.sizes.clone(),
        objects: s.objects.clone(),
        seeds: s.seeds,
        first_seed: s.first_seed,
        episodes: s.episodes,
        sample: s.sample,
        levels: s.levels.clone(),
        done: DoneArgs {
            done: s.done == Some(true),
            no_done: s.done == Some(false),
        },
    }
}

/// The evaluation `eval`'s flags describe (its checkpoint and output are the run's).
fn eval_spec(a: &EvalArgs) -> EvalSpec {
    let EvalArgs {
        checkpoint: _,
        out: _,
        sweep,
        alpha,
        saliency,
        top_k,
        min_success,
        min_acc_ng,
        quiet: _,
        export_failures,
        html,
        jobs,
    } = a;
    EvalSpec {
        sweep: sweep_spec(sweep),
        alpha: *alpha,
        saliency: *saliency,
        top_k: *top_k,
        min_success: *min_success,
        min_acc_ng: *min_acc_ng,
        export_failures: *export_failures,
        html: *html,
        jobs: *jobs,
    }
}

/// `eval`'s arguments for `spec` of the run in `run` (its checkpoint, its report in `eval/`).
pub(super) fn eval_args(spec: &EvalSpec, run: &Path) -> EvalArgs {
    let EvalSpec {
        sweep,
        alpha,
        saliency,
        top_k,
        min_success,
        min_acc_ng,
        export_failures,
        html,
        jobs,
    } = spec;
    EvalArgs {
        checkpoint: vec![run.display().to_string()],
        out: run.join("eval"),
        sweep: sweep_args(sweep),
        alpha: *alpha,
        saliency: *saliency,
        top_k: *top_k,
        min_success: *min_success,
        min_acc_ng: *min_acc_ng,
        quiet: true,
        export_failures: *export_failures,
        html: *html,
        jobs: *jobs,
    }
}

/// The faithfulness run `faithfulness`'s flags describe (no parts named: all three).
fn faithfulness_spec(a: &FaithfulnessArgs) -> FaithfulnessSpec {
    let FaithfulnessArgs {
        checkpoint: _,
        out: _,
        sweep,
        parts,
        jobs,
        quiet: _,
    } = a;
    let wants = |p| parts.is_empty() || parts.contains(&p);
    FaithfulnessSpec {
        sweep: sweep_spec(sweep),
        parts: FaithParts {
            steps: wants(Part::Steps),
            closed_loop: wants(Part::ClosedLoop),
            counterfactuals: wants(Part::Counterfactuals),
        },
        jobs: *jobs,
    }
}

/// `faithfulness`'s arguments for `spec` of the run in `run` (its report in `faithfulness/`).
pub(super) fn faithfulness_args(spec: &FaithfulnessSpec, run: &Path) -> FaithfulnessArgs {
    let FaithfulnessSpec { sweep, parts, jobs } = spec;
    let FaithParts {
        steps,
        closed_loop,
        counterfactuals,
    } = *parts;
    let parts = [
        (steps, Part::Steps),
        (closed_loop, Part::ClosedLoop),
        (counterfactuals, Part::Counterfactuals),
    ]
    .into_iter()
    .filter_map(|(on, part)| on.then_some(part))
    .collect();
    FaithfulnessArgs {
        checkpoint: vec![run.display().to_string()],
        out: run.join("faithfulness"),
        sweep: sweep_args(sweep),
        parts,
        jobs: *jobs,
        quiet: true,
    }
}
