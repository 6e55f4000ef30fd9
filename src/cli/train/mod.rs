//! `groundscope train`: flags into a [`groundscope::run::RunSpec`], the run's progress on the
//! terminal, and Ctrl-C. The run itself — lock, resume, warm start, logs, checkpoints, curve,
//! clean-up — is [`groundscope::run`]'s.

mod args;
mod flags;

use std::path::Path;

use clap::ArgMatches;
use groundscope::metrics::tracking::TrackedEval;
use groundscope::policy::ppo::{LevelMix, PpoConfig, UpdateLog};
use groundscope::policy::{ModelConfig, Variant};
use groundscope::run::{Run, RunDir, RunRecipe, RunSpec, Start, WarmStart};

use crate::ExitStatus;
use crate::cli::policy_cmd::parse_variant;
use crate::cli::stop::Stop;
pub use args::TrainArgs;
use args::{level_mix, ppo_config};

/// Runs `train`.
pub fn run(args: &TrainArgs, matches: Option<&ArgMatches>) -> anyhow::Result<ExitStatus> {
    let (_, model) = model_of(args)?;
    let mut run = if args.resume {
        if !args.teacher.is_empty() {
            anyhow::bail!(
                "--teacher: a resumed run keeps the teachers it was started with; leave the flag out"
            );
        }
        let resumable = Run::resume(&args.out).map_err(|e| flags::refusal(e, "--resume", None))?;
        for n in resumable.notices() {
            eprintln!("groundscope: {n}");
        }
        // The run's own settings are checked once its directory is locked and loaded.
        let given = flags::resume_spec(args, matches, model, resumable.info())?;
        flags::check_resume(matches, resumable.info(), &given, &args.out)?;
        resumable
            .start(given.frames, given.tracking)
            .map_err(|e| flags::refusal(e, "--resume", None))?
    } else {
        // What the flags can get wrong is refused here, with the flags' own messages; the
        // run checks the rest (the parent's words, imitation's labels) before it makes its
        // directory.
        let (ppo, levels) = new_run(args, &model)?;
        let start = match &args.init {
            Some(name) => Start::Init {
                parent: Box::new(flags::parent(name, &model, args, matches)?),
                levels,
                ppo,
                seed: args.seed,
            },
            None => Start::New {
                model,
                levels,
                ppo,
                seed: args.seed,
            },
        };
        let spec = RunSpec {
            start,
            frames: args.frames,
            tracking: flags::tracking(args, matches, None),
            teachers: flags::teachers(args)?,
        };
        let run = Run::create(&args.out, spec)
            .map_err(|e| flags::refusal(e, "--out", args.init.as_deref()))?;
        for what in run.unlabelled() {
            eprintln!(
                "groundscope: warning: --imitate: the bot labels almost nothing of {what}: its episodes give imitation no labels"
            );
        }
        run
    };
    run.on_notice(|n| eprintln!("groundscope: {n}"));
    Ok(steps(run, args.quiet, &Stop::install())?.0)
}

/// A study's training step as data, from the recipe's flags (`matches`: which were given):
/// what they ask of a new run, refused as `train` refuses its flags before it touches its run
/// directory — the model, the intervals, the network's options, the PPO settings and the
/// levels (an unknown id included) — with the same messages, reading no file, so that a value
/// every run refuses is one line at plan time, not a failure once the study runs. For a warm
/// start: the parent and the network flags given, which the parent must share when the run
/// starts (a parent and `--imitate`'s labels are read from files, when the training starts).
/// A recipe never resumes by a flag: its run does so by itself ([`study_train`]).
pub(in crate::cli) fn recipe(
    args: &TrainArgs,
    matches: Option<&ArgMatches>,
) -> anyhow::Result<RunRecipe> {
    if args.resume {
        anyhow::bail!("--resume: a study's run resumes by itself; leave the flag out");
    }
    let (_, model) = model_of(args)?;
    let (ppo, levels) = new_run(args, &model)?;
    let init = args.init.as_ref().map(|parent| WarmStart {
        parent: parent.clone(),
        fixed: flags::network_given(args, &model, matches),
    });
    Ok(RunRecipe {
        model,
        levels,
        ppo,
        seed: args.seed,
        frames: args.frames,
        tracking: flags::tracking(args, matches, None),
        init,
        teachers: flags::teachers(args)?,
    })
}

/// A study's training step, in this process: the run of `recipe` in the directory `dir` the
/// caller has locked ([`RunDir::claim`]) — started where it holds no run (a warm start's
/// parent loaded and checked now), resumed where it holds one, refusing one that differs from
/// the recipe ([`RunRecipe::resume_differences`]: the directory then holds another run) —
/// and trained to its frames or until `stop`, with `train --quiet`'s lines. Returns how it
/// ended and the directory, still locked, for the steps that follow.
pub(in crate::cli) fn study_train(
    recipe: &RunRecipe,
    dir: RunDir,
    stop: &Stop,
) -> anyhow::Result<(ExitStatus, RunDir)> {
    let mut run = if dir.holds_run() {
        let resumable = Run::resume_in(dir).map_err(|e| flags::refusal(e, "--resume", None))?;
        for n in resumable.notices() {
            eprintln!("groundscope: {n}");
        }
        if let Some(d) = recipe.resume_differences(resumable.info()).first() {
            anyhow::bail!(
                "{} holds a run started with {} {}, and the study plans it with {}: not this study's run; move it away to run the study's",
                resumable.dir().display(),
                d.field,
                d.stored,
                d.given
            );
        }
        resumable
            .start(recipe.frames, recipe.tracking)
            .map_err(|e| flags::refusal(e, "--resume", None))?
    } else {
        let start = match &recipe.init {
            Some(w) => Start::Init {
                parent: Box::new(flags::warm_parent(
                    &w.parent,
                    &recipe.model,
                    recipe.seed,
                    &|id: &str| w.fixed.iter().any(|f| f == id),
                )?),
                levels: recipe.levels.clone(),
                ppo: recipe.ppo,
                seed: recipe.seed,
            },
            None => Start::New {
                model: recipe.model,
                levels: recipe.levels.clone(),
                ppo: recipe.ppo,
                seed: recipe.seed,
            },
        };
        let spec = RunSpec {
            start,
            frames: recipe.frames,
            tracking: recipe.tracking,
            teachers: recipe.teachers.clone(),
        };
        let init = recipe.init.as_ref().map(|w| w.parent.as_str());
        let run = Run::create_in(dir, spec).map_err(|e| flags::refusal(e, "--out", init))?;
        for what in run.unlabelled() {
            eprintln!(
                "groundscope: warning: --imitate: the bot labels almost nothing of {what}: its episodes give imitation no labels"
            );
        }
        run
    };
    run.on_notice(|n| eprintln!("groundscope: {n}"));
    steps(run, true, stop)
}

/// The model the flags ask for, and the interval flags checked (every run, resumed or not).
fn model_of(args: &TrainArgs) -> anyhow::Result<(Variant, ModelConfig)> {
    let variant = parse_variant(&args.model)?;
    let model = args.model_options.apply(ModelConfig {
        lstm_hidden: args.hidden,
        gru_hidden: args.hidden,
        ..ModelConfig::new(variant)
    })?;
    if args.save_interval == 0 {
        anyhow::bail!("--save-interval 0: must be at least 1 update");
    }
    if args.eval_interval > 0 && args.eval_episodes == 0 {
        anyhow::bail!(
            "--eval-episodes 0: must be at least 1 (--eval-interval 0 turns the tracked evaluation off)"
        );
    }
    Ok((variant, model))
}

/// A new run's network options, PPO settings and levels, each checked.
fn new_run(args: &TrainArgs, model: &ModelConfig) -> anyhow::Result<(PpoConfig, LevelMix)> {
    model.validate()?;
    let ppo = ppo_config(args, model.word_temperature.0)?;
    ppo.validate()?;
    let levels = level_mix(args)?;
    Ok((ppo, levels))
}

/// Steps `run` until it has trained its frames or `stop` is asked for (Ctrl-C, SIGTERM and
/// SIGHUP all stop after the current update and save), showing progress (`quiet`: a line
/// every ten updates and the tracked evaluations instead of a bar). Returns the exit status
/// and the run's directory, still locked.
fn steps(mut run: Run, quiet: bool, stop: &Stop) -> anyhow::Result<(ExitStatus, RunDir)> {
    let bar = if quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(run.target_frames())
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} frames {msg} ETA {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let t = run.trainer();
    bar.set_position(t.state.frames);
    println!(
        "training {} on {} ({} parameters), {} frames/update, from frame {}",
        t.model.variant.name(),
        t.levels,
        t.params.count(),
        t.ppo.frames_per_update(),
        t.state.frames
    );
    while !run.done() && !stop.requested() {
        let p = run.update()?;
        let (log, fps) = (&p.log, p.fps);
        bar.set_position(log.frames);
        bar.set_message(format!(
            "{fps:.0} fps, success {:.2}, reward {:.3}",
            log.success_rate, log.mean_reward
        ));
        if quiet && log.update % 10 == 0 {
            // The grounding term is shown only where it is trained.
            let ground = if run.trainer().ppo.ground_loss > 0.0 {
                format!(" ground {:.3}", log.ground_loss)
            } else {
                String::new()
            };
            println!(
                "update {} frames {} fps {fps:.0} success {:.3} reward {:.3} entropy {:.3}{ground}",
                log.update, log.frames, log.success_rate, log.mean_reward, log.entropy
            );
        }
        if quiet {
            print_evals(&p.evals);
        }
    }
    let dir = run.dir().to_path_buf();
    let counts = Counts {
        frames: run.trainer().state.frames,
        updates: run.trainer().state.updates,
        target: run.target_frames(),
    };
    let (last, locked) = run.finish_keeping_dir()?;
    bar.finish_and_clear();
    Ok((say_end(&dir, last.as_ref(), counts), locked))
}

/// Where a run's training ended: its frames and updates, and the frames it trains to.
#[derive(Clone, Copy)]
struct Counts {
    frames: u64,
    updates: u64,
    target: u64,
}

/// The line that says how the run in `dir` ended (`last`: its last update's log), and the
/// exit status. A run that a signal stopped before its `--frames` is a stopped run, not a
/// finished one: it is saved like any other (the checkpoint first), then ends with 130
/// (docs/training.md#what-a-stopped-run-is), so that whoever runs it — a study's exec, a
/// script — resumes it instead of taking the part-trained model as the final one.
fn say_end(dir: &Path, last: Option<&UpdateLog>, counts: Counts) -> ExitStatus {
    let Counts {
        frames,
        updates,
        target,
    } = counts;
    let stopped = frames < target;
    let why = if stopped {
        "interrupted; saved"
    } else {
        "done"
    };
    println!(
        "{why}: {frames} frames, {updates} updates, last success {:.3}, reward {:.3}; checkpoint {}",
        last.map_or(f64::NAN, |l| l.success_rate),
        last.map_or(f64::NAN, |l| l.mean_reward),
        dir.join("model").display()
    );
    if stopped {
        eprintln!(
            "groundscope: interrupted at frame {frames} of {target}, saved: not finished (exit 130); go on with --resume"
        );
        return ExitStatus::Interrupted;
    }
    ExitStatus::Success
}

/// The tracked evaluation's rows as `--quiet` prints them.
fn print_evals(rows: &[TrackedEval]) {
    for row in rows {
        println!(
            "eval update {} frames {} {}: greedy success {:.3} object acc_ng {:.3} colour acc_ng {:.3} ({:.1} s)",
            row.update,
            row.frames,
            row.level,
            row.greedy_success,
            row.object.1,
            row.color.1,
            row.eval_secs
        );
    }
}
