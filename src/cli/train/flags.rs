//! `train`'s flags against what a run already fixed, and the run's own setting names turned
//! into flags: on `--resume` the run's differences from the flags given ([`RunInfo::differences`]:
//! a flag left out takes the run's value, one given with another value is refused naming it),
//! with `--init` the parent's network, the tracking flags a run keeps, and the run's errors.

use std::path::Path;

use anyhow::Context as _;
use clap::ArgMatches;
use clap::parser::ValueSource;
use groundscope::env::{LevelConfig, TaskSet};
use groundscope::policy::ModelConfig;
use groundscope::policy::ppo::{LevelMix, TeacherSpec};
use groundscope::run::{Parent, RunError, RunInfo, RunSpec, Start, Tracking, model_options};

use super::args::{TrainArgs, level_mix, ppo_config};

/// The tracking settings of this invocation: the flags given, and on `--resume` the run's own
/// settings for those left out (a run saved before they were kept takes the defaults).
pub(super) fn tracking(
    args: &TrainArgs,
    matches: Option<&ArgMatches>,
    run: Option<Tracking>,
) -> Tracking {
    let pick = |id: &str, now: u64, saved: Option<u64>| match saved {
        Some(v) if !given(matches, id) => v,
        _ => now,
    };
    Tracking {
        eval_interval: pick(
            "eval_interval",
            args.eval_interval,
            run.map(|t| t.eval_interval),
        ),
        eval_episodes: pick(
            "eval_episodes",
            args.eval_episodes,
            run.map(|t| t.eval_episodes),
        ),
        save_interval: Some(pick(
            "save_interval",
            args.save_interval,
            run.and_then(|t| t.save_interval),
        )),
    }
}

/// `--resume`: what the flags say of the run in `info` — the network as `model` (the flags'),
/// the levels as the level flags describe them (the run's own where none is given), the PPO
/// settings and the seed as given or by default — to compare with the run's
/// ([`check_resume`]), and the tracking to go on with.
pub(super) fn resume_spec(
    args: &TrainArgs,
    matches: Option<&ArgMatches>,
    model: ModelConfig,
    info: &RunInfo,
) -> anyhow::Result<RunSpec> {
    Ok(RunSpec {
        start: Start::New {
            model,
            levels: resume_levels(args, matches, info)?,
            ppo: ppo_config(args, info.model.word_temperature.0)?,
            seed: args.seed,
        },
        frames: args.frames,
        tracking: tracking(args, matches, info.tracking),
        teachers: Vec::new(),
    })
}

/// The levels the level flags describe on `--resume`: `--levels` or `--level` as a new run
/// reads them; the paper's level as `--size`, `--objects`, `--tasks` and the mode flags
/// describe it (not checked: a value the run does not have is refused as a difference); the
/// run's own where no level flag is given.
fn resume_levels(
    args: &TrainArgs,
    matches: Option<&ArgMatches>,
    info: &RunInfo,
) -> anyhow::Result<LevelMix> {
    if args.levels.is_some() || args.level.level.is_some() {
        return level_mix(args);
    }
    let paper_flags = [
        "size",
        "objects",
        "tasks",
        "no_done",
        "done",
        "always_color",
    ];
    if !paper_flags.iter().any(|id| given(matches, id)) {
        return Ok(info.levels.clone());
    }
    let a = &args.level;
    Ok(LevelConfig {
        room_size: a.size,
        n_objects: a.objects,
        tasks: TaskSet::parse(&a.tasks)?,
        done_required: !a.no_done,
        color_optional: !a.always_color,
        babyai: None,
    }
    .into())
}

/// `--resume`: refuses a flag given with a value other than the run's in `dir` (`info`, what
/// it was started with; `spec`, what the flags say); the mode flags (`--done`, `--no-done`,
/// `--always-color`) must say what the run does.
pub(super) fn check_resume(
    matches: Option<&ArgMatches>,
    info: &RunInfo,
    spec: &RunSpec,
    dir: &Path,
) -> anyhow::Result<()> {
    for d in info.differences(spec) {
        let Some(id) = flag_ids(d.field).into_iter().find(|id| given(matches, id)) else {
            continue;
        };
        let flag = id.replace('_', "-");
        let (stored, now) = (&d.stored, &d.given);
        match d.field {
            "variant" => anyhow::bail!(
                "--resume: {} holds a {stored} model, not {now}",
                dir.display()
            ),
            "done_required" | "color_optional" => {
                let mode = match (d.field, stored.as_str()) {
                    ("done_required", "true") => "in the done-action mode",
                    ("done_required", _) => "without the done action",
                    _ => "without --always-color",
                };
                anyhow::bail!(
                    "--resume: the run in {} was started {mode}, not with --{flag}; leave the flag out to keep the run's mode",
                    dir.display()
                );
            }
            _ => anyhow::bail!(
                "--resume: the run in {} was started with --{flag} {stored}, not {now}; leave the flag out to keep the run's value",
                dir.display()
            ),
        }
    }
    Ok(())
}

/// The flags (clap ids) that give a run's setting `field` ([`RunInfo::differences`]'s names),
/// the one shown in a message being the one given.
fn flag_ids(field: &'static str) -> Vec<&'static str> {
    match field {
        "variant" => vec!["model"],
        "levels" => vec!["levels", "level"],
        "room_size" => vec!["size"],
        "n_objects" => vec!["objects"],
        "temperature_anneal" => vec!["word_temperature_anneal"],
        "done_required" => vec!["no_done", "done"],
        "color_optional" => vec!["always_color"],
        other => vec![other],
    }
}

/// The flag that gives a run's setting `field`, as a message shows it (`--hidden`); the
/// network's and PPO's own checks (`model`, `ppo`) name their flags in their reason.
fn flag(field: &'static str) -> Option<String> {
    match field {
        "model" | "ppo" => None,
        field => flag_ids(field)
            .first()
            .map(|id| format!("--{}", id.replace('_', "-"))),
    }
}

/// The run's error as `train` says it: its settings named by their flags, how to go on by
/// the command's (`--resume`, `--init`, `--out`); `how` is the flag the run's directory came
/// with (`--out` for a new run, `--resume`), `init` the `--init` parent's name.
pub(super) fn refusal(e: RunError, how: &str, init: Option<&str>) -> anyhow::Error {
    match e {
        RunError::Occupied(dir) => anyhow::anyhow!(
            "{} already holds a run; pass --resume to continue it or choose another --out",
            dir.display()
        ),
        RunError::NothingToResume(dir) => anyhow::anyhow!(
            "--resume: {} holds no checkpoint to resume (a run stopped before its first save); start it again without --resume",
            dir.display()
        ),
        RunError::BadLog { what, .. } => anyhow::anyhow!(
            "{how}: {what}; restore it, or start a new run from this one's weights with --init"
        ),
        RunError::BotParent => anyhow::anyhow!(
            "--init {}: the bot is a planner with no network weights to start from; to learn from it, train with --imitate",
            init.unwrap_or(groundscope::policy::acting::BOT)
        ),
        RunError::Invalid {
            field: "init",
            reason,
        } => match init {
            Some(name) => anyhow::anyhow!("--init {name}: {reason}"),
            None => anyhow::anyhow!("--init: {reason}"),
        },
        RunError::Invalid { field, reason } => match flag(field) {
            Some(flag) => anyhow::anyhow!("{flag}: {reason}"),
            None => anyhow::anyhow!("{reason}"),
        },
        e => anyhow::Error::from(e).context(how.to_owned()),
    }
}

/// `--init NAME`: the parent for the network `model` the flags describe ([`warm_parent`]),
/// the network flags given on the command line being the settings it must share.
pub(super) fn parent(
    name: &str,
    model: &ModelConfig,
    args: &TrainArgs,
    matches: Option<&ArgMatches>,
) -> anyhow::Result<Parent> {
    let fixed = network_given(args, model, matches);
    warm_parent(name, model, args.seed, &|id: &str| {
        fixed.iter().any(|f| f == id)
    })
}

/// The network settings given on the command line (`hidden`, a model option's id): what a warm
/// start must share with its parent.
pub(super) fn network_given(
    args: &TrainArgs,
    model: &ModelConfig,
    matches: Option<&ArgMatches>,
) -> Vec<String> {
    std::iter::once("hidden")
        .chain(args.model_options.against(model).map(|(id, _, _)| id))
        .filter(|id| given(matches, id))
        .map(str::to_owned)
        .collect()
}

/// A warm start's parent `name` for a run that asks for the network `want` (seeded by `seed`),
/// refusing a checkpoint of the other model or a setting in `fixed` (`hidden`, a model
/// option's id: what the run gives itself) that differs from the parent's, except
/// `layout_path` and `search_query`, which grow a parent without them
/// ([`Parent::grow_layout_path`], [`Parent::grow_search_query`]), and `filter_norm`, which
/// has no weights ([`Parent::add_filter_norm`]). (Levels with words it lacks are refused by
/// the run, before it touches its directory.) The refusals name `train`'s flags, as a study's
/// recipe gives them too.
pub(super) fn warm_parent(
    name: &str,
    want: &ModelConfig,
    seed: u64,
    fixed: &dyn Fn(&str) -> bool,
) -> anyhow::Result<Parent> {
    let mut parent = Parent::load(name).map_err(|e| match e {
        e @ (RunError::BotParent | RunError::Invalid { .. }) => refusal(e, "--init", Some(name)),
        e => anyhow::Error::from(e).context(format!("--init {name}")),
    })?;
    if want.layout_path {
        // The one option a warm start may add: its weights start at zero, so the run begins
        // with its parent's behaviour.
        parent
            .grow_layout_path(seed)
            .with_context(|| format!("--init {name} --layout-path"))?;
    }
    if want.search_query {
        // Grown as the layout path is: zero columns, the parent's behaviour at the start.
        parent
            .grow_search_query(seed.wrapping_add(1))
            .with_context(|| format!("--init {name} --search-query"))?;
    }
    if want.filter_norm {
        // It has no weights: the parent's, with its filter's output rescaled.
        parent
            .add_filter_norm()
            .with_context(|| format!("--init {name} --filter-norm"))?;
    }
    let model = &parent.checkpoint.meta.model;
    if model.variant != want.variant {
        anyhow::bail!(
            "--init: {name} is a {} model, not {}",
            model.variant.name(),
            want.variant.name()
        );
    }
    if fixed("hidden") && want.lstm_hidden != model.lstm_hidden {
        anyhow::bail!(
            "--init: {name} has hidden size {}, not --hidden {}",
            model.lstm_hidden,
            want.lstm_hidden
        );
    }
    for ((id, now), (_, theirs)) in model_options(want).into_iter().zip(model_options(model)) {
        if fixed(id) && now != theirs {
            let flag = id.replace('_', "-");
            anyhow::bail!("--init: {name} was trained with --{flag} {theirs}, not --{flag} {now}");
        }
    }
    Ok(parent)
}

/// Whether flag `id` was given on the command line rather than left at its default.
pub(super) fn given(matches: Option<&ArgMatches>, id: &str) -> bool {
    matches.is_some_and(|m| m.value_source(id) == Some(ValueSource::CommandLine))
}

/// `--teacher`'s values, each parsed ([`TeacherSpec::parse`]); refused without `--imitate`.
pub(super) fn teachers(args: &TrainArgs) -> anyhow::Result<Vec<TeacherSpec>> {
    if !args.teacher.is_empty() && !args.imitate {
        anyhow::bail!("--teacher: a teacher labels imitation's frames; add --imitate");
    }
    Ok(args
        .teacher
        .iter()
        .map(|t| TeacherSpec::parse(t))
        .collect::<Result<_, _>>()?)
}
