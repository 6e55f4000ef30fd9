//! What a resumed run was started with, and where a caller's settings differ from it.

use super::{RunSpec, Tracking};
use crate::env::LevelConfig;
use crate::policy::ppo::{LevelMix, PpoConfig};
use crate::policy::{ModelConfig, TrainingState, Variant};

/// What a resumed run was started with.
pub struct RunInfo {
    /// Its seed.
    pub seed: u64,
    /// Its PPO settings.
    pub ppo: PpoConfig,
    /// Its levels.
    pub levels: LevelMix,
    /// Its hidden size.
    pub hidden: usize,
    /// Its network (sizes and model options).
    pub model: ModelConfig,
    /// Its model variant.
    pub variant: Variant,
    /// Its progress.
    pub training: TrainingState,
    /// Its tracking settings, where the run recorded them.
    pub tracking: Option<Tracking>,
}

/// A setting a caller gives otherwise than the run has it: a resume keeps the run's own
/// settings, so a front end refuses the ones its user gave (naming its flag or keyword for
/// `field`) and lets the others take the run's value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Difference {
    /// The setting, by the run's name for it: `variant`, a [`PpoConfig`] field, `levels`,
    /// `hidden`, `seed`, the first level's `room_size`, `n_objects`, `tasks`, `done_required`
    /// and `color_optional`, or a [`ModelConfig`] option (`conv_kernel`, …, `filter_norm`).
    pub field: &'static str,
    /// The run's value.
    pub stored: String,
    /// The caller's value.
    pub given: String,
}

impl RunInfo {
    /// The settings of `spec` that differ from the run's, in a fixed order (the model
    /// variant first, the level modes last). Frames and tracking are not settings a run
    /// keeps against its caller (a resume may change them); the word temperature is
    /// compared with the checkpoint's (an annealed run's moves).
    pub fn differences(&self, spec: &RunSpec) -> Vec<Difference> {
        let start = &spec.start;
        let (model, ppo) = (start.model(), start.ppo());
        let (run, now) = (&self.ppo, ppo);
        let (run_level, now_level) = (self.levels.first(), start.levels().first());
        let schedule = |p: &PpoConfig| {
            p.temperature_anneal
                .map_or_else(String::new, |a| format!("{}:{}", a.start, a.end))
        };
        let freeze = |p: &PpoConfig| {
            p.freeze_attention_at
                .map_or_else(String::new, |f| f.to_string())
        };
        let tasks = |l: &LevelConfig| format!("{:?}", l.tasks).to_lowercase();
        let pair = |field: &'static str, stored: String, given: String| Difference {
            field,
            stored,
            given,
        };
        let mut all = vec![
            pair(
                "variant",
                self.variant.name().to_owned(),
                model.variant.name().to_owned(),
            ),
            pair(
                "ground_loss",
                run.ground_loss.to_string(),
                now.ground_loss.to_string(),
            ),
            pair(
                "imitate_policy_share",
                run.imitate_policy_share.to_string(),
                now.imitate_policy_share.to_string(),
            ),
            pair(
                "levels",
                self.levels.to_string(),
                start.levels().to_string(),
            ),
            pair("imitate", run.imitate.to_string(), now.imitate.to_string()),
            pair("temperature_anneal", schedule(run), schedule(now)),
            pair("freeze_attention_at", freeze(run), freeze(now)),
            pair(
                "reward_scale",
                run.reward_scale.to_string(),
                now.reward_scale.to_string(),
            ),
            pair(
                "normalize_advantages",
                run.normalize_advantages.to_string(),
                now.normalize_advantages.to_string(),
            ),
            pair("procs", run.procs.to_string(), now.procs.to_string()),
            pair(
                "frames_per_proc",
                run.frames_per_proc.to_string(),
                now.frames_per_proc.to_string(),
            ),
            pair("epochs", run.epochs.to_string(), now.epochs.to_string()),
            pair(
                "batch_size",
                run.batch_size.to_string(),
                now.batch_size.to_string(),
            ),
            pair(
                "recurrence",
                run.recurrence.to_string(),
                now.recurrence.to_string(),
            ),
            pair("lr", run.lr.to_string(), now.lr.to_string()),
            pair(
                "adam_eps",
                run.adam_eps.to_string(),
                now.adam_eps.to_string(),
            ),
            pair(
                "discount",
                run.discount.to_string(),
                now.discount.to_string(),
            ),
            pair(
                "gae_lambda",
                run.gae_lambda.to_string(),
                now.gae_lambda.to_string(),
            ),
            pair(
                "entropy_coef",
                run.entropy_coef.to_string(),
                now.entropy_coef.to_string(),
            ),
            pair(
                "value_loss_coef",
                run.value_loss_coef.to_string(),
                now.value_loss_coef.to_string(),
            ),
            pair(
                "max_grad_norm",
                run.max_grad_norm.to_string(),
                now.max_grad_norm.to_string(),
            ),
            pair(
                "clip_eps",
                run.clip_eps.to_string(),
                now.clip_eps.to_string(),
            ),
            pair("threads", run.threads.to_string(), now.threads.to_string()),
            pair(
                "hidden",
                self.hidden.to_string(),
                model.lstm_hidden.to_string(),
            ),
            pair("seed", self.seed.to_string(), start.seed().to_string()),
            pair(
                "room_size",
                run_level.room_size.to_string(),
                now_level.room_size.to_string(),
            ),
            pair(
                "n_objects",
                run_level.n_objects.to_string(),
                now_level.n_objects.to_string(),
            ),
            pair("tasks", tasks(&run_level), tasks(&now_level)),
        ];
        all.extend(
            model_options(&self.model)
                .into_iter()
                .zip(model_options(model))
                .map(|((field, stored), (_, given))| pair(field, stored, given)),
        );
        all.extend([
            pair(
                "done_required",
                run_level.done_required.to_string(),
                now_level.done_required.to_string(),
            ),
            pair(
                "color_optional",
                run_level.color_optional.to_string(),
                now_level.color_optional.to_string(),
            ),
        ]);
        all.retain(|d| d.stored != d.given);
        all
    }
}

/// The model options a checkpoint keeps (the network's choices beyond its sizes), each by
/// its field's name, as text.
pub fn model_options(cfg: &ModelConfig) -> [(&'static str, String); 11] {
    [
        ("conv_kernel", cfg.conv_kernel.to_string()),
        ("filter_scale", cfg.filter_scale.to_string()),
        ("colour_codes", cfg.colour_codes.name().to_owned()),
        ("word_temperature", cfg.word_temperature.0.to_string()),
        (
            "key_kernel",
            cfg.key_kernel
                .map_or_else(|| "shared".to_owned(), |k| k.to_string()),
        ),
        ("attend_words", cfg.attend_words.name().to_owned()),
        ("search_query", cfg.search_query.to_string()),
        ("null_key", cfg.null_key.to_string()),
        ("key_context", cfg.key_context.to_string()),
        ("layout_path", cfg.layout_path.to_string()),
        ("filter_norm", cfg.filter_norm.to_string()),
    ]
}
