//! `train`'s flags against what a run already fixed: on `--resume` the run's own settings
//! (a flag left out takes the run's value, one given with another value is refused naming
//! it), with `--init` the parent's network, and the tracking flags a run keeps.

use std::path::Path;

use anyhow::Context as _;
use clap::ArgMatches;
use clap::parser::ValueSource;
use groundscope::policy::ppo::PpoConfig;
use groundscope::policy::ppo::run_dir::{RunInfo, Tracking};
use groundscope::run::Parent;

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

/// `--resume`: refuses flags that contradict the run in `dir` (`info`, what it was started
/// with).
pub(super) fn check_resume(
    args: &TrainArgs,
    matches: Option<&ArgMatches>,
    variant: groundscope::policy::Variant,
    info: &RunInfo,
    dir: &Path,
) -> anyhow::Result<()> {
    if info.variant != variant && given(matches, "model") {
        anyhow::bail!(
            "--resume: {} holds a {} model, not {}",
            dir.display(),
            info.variant.name(),
            variant.name()
        );
    }
    let saved = Fixed {
        ppo: info.ppo,
        levels: info.levels.clone(),
        hidden: info.hidden,
        model: info.model,
        seed: info.seed,
    };
    saved.check_given(args, matches, "--resume", dir)
}

/// `--init NAME`: the parent, refusing a checkpoint of the other model or a `--hidden` or
/// model option (`--conv-kernel`, …) that differs from its own, except `--layout-path` and
/// `--search-query`, which grow a parent without them ([`Parent::grow_layout_path`],
/// [`Parent::grow_search_query`]), and `--filter-norm`, which has no weights
/// ([`Parent::add_filter_norm`]); and levels with words it lacks.
pub(super) fn parent(
    name: &str,
    variant: groundscope::policy::Variant,
    levels: &groundscope::policy::ppo::LevelMix,
    args: &TrainArgs,
    matches: Option<&ArgMatches>,
) -> anyhow::Result<Parent> {
    let mut parent = Parent::load(name).with_context(|| format!("--init {name}"))?;
    if args.model_options.layout_path {
        // The one option a warm start may add: its weights start at zero, so the run begins
        // with its parent's behaviour.
        parent
            .grow_layout_path(args.seed)
            .with_context(|| format!("--init {name} --layout-path"))?;
    }
    if args.model_options.search_query {
        // Grown as the layout path is: zero columns, the parent's behaviour at the start.
        parent
            .grow_search_query(args.seed.wrapping_add(1))
            .with_context(|| format!("--init {name} --search-query"))?;
    }
    if args.model_options.filter_norm {
        // It has no weights: the parent's, with its filter's output rescaled.
        parent
            .add_filter_norm()
            .with_context(|| format!("--init {name} --filter-norm"))?;
    }
    let model = &parent.checkpoint.meta.model;
    if model.variant != variant {
        anyhow::bail!(
            "--init: {name} is a {} model, not {}",
            model.variant.name(),
            variant.name()
        );
    }
    if given(matches, "hidden") && args.hidden != model.lstm_hidden {
        anyhow::bail!(
            "--init: {name} has hidden size {}, not --hidden {}",
            model.lstm_hidden,
            args.hidden
        );
    }
    for (id, now, theirs) in args.model_options.against(model) {
        if given(matches, id) && now != theirs {
            let flag = id.replace('_', "-");
            anyhow::bail!("--init: {name} was trained with --{flag} {theirs}, not --{flag} {now}");
        }
    }
    parent
        .check_words(levels)
        .with_context(|| format!("--init {name}"))?;
    Ok(parent)
}

/// Whether flag `id` was given on the command line rather than left at its default.
fn given(matches: Option<&ArgMatches>, id: &str) -> bool {
    matches.is_some_and(|m| m.value_source(id) == Some(ValueSource::CommandLine))
}

/// What a run fixes at its start. On `--resume` a flag left out takes the run's value, and a
/// flag given with another value is an error rather than silently ignored.
struct Fixed {
    ppo: PpoConfig,
    levels: groundscope::policy::ppo::LevelMix,
    hidden: usize,
    model: groundscope::policy::ModelConfig,
    seed: u64,
}

impl Fixed {
    fn check_given(
        &self,
        args: &TrainArgs,
        matches: Option<&ArgMatches>,
        how: &str,
        dir: &Path,
    ) -> anyhow::Result<()> {
        let (now, run) = (ppo_config(args, self.model.word_temperature.0)?, &self.ppo);
        let a = &args.level;
        let l = &self.levels.first();
        // The levels as given, or as the run has them where the flag is left out.
        let levels_now = if args.levels.is_some() || args.level.level.is_some() {
            level_mix(args)?.to_string()
        } else {
            self.levels.to_string()
        };
        let schedule = |p: &PpoConfig| {
            p.temperature_anneal
                .map_or_else(String::new, |a| format!("{}:{}", a.start, a.end))
        };
        let freeze = |p: &PpoConfig| {
            p.freeze_attention_at
                .map_or_else(String::new, |f| f.to_string())
        };
        let pairs: [(&str, String, String); 28] = [
            (
                "ground_loss",
                now.ground_loss.to_string(),
                run.ground_loss.to_string(),
            ),
            (
                "imitate_policy_share",
                now.imitate_policy_share.to_string(),
                run.imitate_policy_share.to_string(),
            ),
            ("levels", levels_now.clone(), self.levels.to_string()),
            ("level", levels_now, self.levels.to_string()),
            ("imitate", now.imitate.to_string(), run.imitate.to_string()),
            ("word_temperature_anneal", schedule(&now), schedule(run)),
            ("freeze_attention_at", freeze(&now), freeze(run)),
            (
                "reward_scale",
                now.reward_scale.to_string(),
                run.reward_scale.to_string(),
            ),
            (
                "normalize_advantages",
                now.normalize_advantages.to_string(),
                run.normalize_advantages.to_string(),
            ),
            ("procs", now.procs.to_string(), run.procs.to_string()),
            (
                "frames_per_proc",
                now.frames_per_proc.to_string(),
                run.frames_per_proc.to_string(),
            ),
            ("epochs", now.epochs.to_string(), run.epochs.to_string()),
            (
                "batch_size",
                now.batch_size.to_string(),
                run.batch_size.to_string(),
            ),
            (
                "recurrence",
                now.recurrence.to_string(),
                run.recurrence.to_string(),
            ),
            ("lr", now.lr.to_string(), run.lr.to_string()),
            (
                "adam_eps",
                now.adam_eps.to_string(),
                run.adam_eps.to_string(),
            ),
            (
                "discount",
                now.discount.to_string(),
                run.discount.to_string(),
            ),
            (
                "gae_lambda",
                now.gae_lambda.to_string(),
                run.gae_lambda.to_string(),
            ),
            (
                "entropy_coef",
                now.entropy_coef.to_string(),
                run.entropy_coef.to_string(),
            ),
            (
                "value_loss_coef",
                now.value_loss_coef.to_string(),
                run.value_loss_coef.to_string(),
            ),
            (
                "max_grad_norm",
                now.max_grad_norm.to_string(),
                run.max_grad_norm.to_string(),
            ),
            (
                "clip_eps",
                now.clip_eps.to_string(),
                run.clip_eps.to_string(),
            ),
            ("threads", now.threads.to_string(), run.threads.to_string()),
            ("hidden", args.hidden.to_string(), self.hidden.to_string()),
            ("seed", args.seed.to_string(), self.seed.to_string()),
            ("size", a.size.to_string(), l.room_size.to_string()),
            ("objects", a.objects.to_string(), l.n_objects.to_string()),
            (
                "tasks",
                task_name(&a.tasks),
                format!("{:?}", l.tasks).to_lowercase(),
            ),
        ];
        for (id, now, run) in pairs
            .into_iter()
            .chain(args.model_options.against(&self.model))
        {
            if given(matches, id) && now != run {
                anyhow::bail!(
                    "{how}: the run in {} was started with --{} {run}, not {now}; leave the flag out to keep the run's value",
                    dir.display(),
                    id.replace('_', "-")
                );
            }
        }
        // One rule for the mode flags: a flag that says what the run already does is
        // accepted, one that contradicts it is refused (never silently ignored).
        for (id, on, mode) in [
            ("no_done", !l.done_required, "in the done-action mode"),
            ("done", l.done_required, "without the done action"),
            ("always_color", !l.color_optional, "without --always-color"),
        ] {
            if given(matches, id) && !on {
                anyhow::bail!(
                    "{how}: the run in {} was started {mode}, not with --{}; leave the flag out to keep the run's mode",
                    dir.display(),
                    id.replace('_', "-")
                );
            }
        }
        Ok(())
    }
}

/// `--tasks` as the run files spell it, so `both` and its aliases compare equal.
fn task_name(given: &str) -> String {
    groundscope::env::TaskSet::parse(given)
        .map_or_else(|_| given.to_owned(), |t| format!("{t:?}").to_lowercase())
}
