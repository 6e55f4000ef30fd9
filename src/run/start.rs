//! What a run starts from, checked before it writes anything: a parent's weights for a warm
//! start, the words its levels need, the bot's labels for imitation, and imitation's teachers.

use super::RunError;
use crate::policy::ppo::{LevelMix, MixEntry, TeacherSpec};
use crate::policy::{Checkpoint, ModelConfig, Params};

/// Trained weights a new run starts from (a warm start), loaded and checked.
pub struct Parent {
    /// The name it was given (a checkpoint, a run directory or `bundled:NAME`).
    pub name: String,
    /// Its weights and metadata; [`Self::grow_layout_path`] may have grown them.
    pub checkpoint: Checkpoint,
}

impl Parent {
    /// Loads `name`, refusing what has no network weights to start from: the bot
    /// ([`RunError::BotParent`]), an ONNX graph (`init` [`RunError::Invalid`]).
    pub fn load(name: &str) -> Result<Self, RunError> {
        if name == crate::policy::acting::BOT {
            return Err(RunError::BotParent);
        }
        if crate::policy::onnx::is_onnx(std::path::Path::new(name)) {
            return Err(RunError::invalid(
                "init",
                "an ONNX graph cannot seed training (it carries no trainable weights for \
                 groundscope's network); give a groundscope checkpoint NAME or run directory",
            ));
        }
        Ok(Self {
            name: name.to_owned(),
            checkpoint: crate::policy::bundled::load(name)?,
        })
    }

    /// Gives the parent a [`crate::policy::ModelConfig::layout_path`] if it has none, the
    /// new weights drawn from `seed` and its LSTM's new columns zero, so the run starts with
    /// the parent's behaviour ([`crate::policy::Params::with_layout_path`]).
    pub fn grow_layout_path(&mut self, seed: u64) -> Result<(), RunError> {
        self.grow(|p, cfg| p.with_layout_path(cfg, seed))
    }

    /// [`Self::grow_layout_path`] for the [`crate::policy::ModelConfig::search_query`]
    /// ([`crate::policy::Params::with_search_query`]): the run starts with the parent's
    /// behaviour.
    pub fn grow_search_query(&mut self, seed: u64) -> Result<(), RunError> {
        self.grow(|p, cfg| p.with_search_query(cfg, seed))
    }

    /// Replaces the parent's config and weights by what `grow` makes of them.
    fn grow(
        &mut self,
        grow: impl FnOnce(
            &crate::policy::Params,
            &crate::policy::ModelConfig,
        ) -> Result<
            (crate::policy::ModelConfig, crate::policy::Params),
            crate::policy::PolicyError,
        >,
    ) -> Result<(), RunError> {
        let ckpt = &mut self.checkpoint;
        let (model, params) = grow(&ckpt.params, &ckpt.meta.model)?;
        ckpt.meta.model = model;
        ckpt.params = params;
        Ok(())
    }

    /// Sets the parent's [`crate::policy::ModelConfig::filter_norm`]: it has no weights, so
    /// the run starts from the parent's with its filter's output rescaled (the same output
    /// where the parent's maps are uniform).
    pub fn add_filter_norm(&mut self) -> Result<(), RunError> {
        let model = crate::policy::ModelConfig {
            filter_norm: true,
            ..self.checkpoint.meta.model
        };
        model.validate()?;
        self.checkpoint.meta.model = model;
        Ok(())
    }

    /// Refuses `levels` whose missions use a word past the parent's vocabulary, naming one
    /// (found in the first [`WORD_CHECK_SEEDS`] missions of each level) as an `init`
    /// [`RunError::Invalid`]: such a run would otherwise fail at the first mission that uses
    /// it, updates later, and its resume at once.
    pub fn check_words(&self, levels: &LevelMix) -> Result<(), RunError> {
        use crate::policy::ModelConfig;
        let known = self.checkpoint.meta.model.vocab_size;
        for entry in levels.entries() {
            let level = &entry.level;
            if known >= ModelConfig::vocab_size_for(level) {
                continue;
            }
            let shown = || level.id();
            for seed in 0..WORD_CHECK_SEEDS {
                let world = level.generate(seed).map_err(|e| {
                    RunError::invalid("levels", format!("level {} seed {seed}: {e}", shown()))
                })?;
                let tokens = crate::env::vocab::tokenize_on_level(&world.mission, shown)
                    .map_err(|e| RunError::invalid("levels", e))?;
                if let Some(&t) = tokens.iter().find(|&&t| t as usize >= known) {
                    return Err(RunError::invalid(
                        "init",
                        format!(
                            "the model knows the paper's {} words, and level {} uses {:?} \
                             (mission {:?}); warm-start from a model trained on a BabyAI level",
                            known - 1,
                            shown(),
                            crate::env::vocab::word(t).unwrap_or("?"),
                            world.mission
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// How many missions of each level [`Parent::check_words`] reads for a word the parent lacks:
/// the levels' grammars show every word class within a few dozen seeds.
const WORD_CHECK_SEEDS: u64 = 200;

/// How many of each level's first training episodes [`check_labels`] runs the bot on.
const LABEL_CHECK_EPISODES: u64 = 20;

/// Below this share of labelled steps a level gives imitation (almost) nothing to learn from.
const LABEL_SHARE_MIN: f64 = 0.01;

/// Imitation learns only from the steps the bot advises. The bot is run alone on each level's
/// first training episodes: a run where every level is labelled under [`LABEL_SHARE_MIN`] of
/// its steps (the bot gives up at once or nearly, as on KeyInBox, or has no plan at all, as on
/// MiniGrid's ids but those rewarded for one pickup: [`crate::bot::plans`]) is refused rather
/// than trained on nothing (an `imitate` [`RunError::Invalid`] naming the levels); otherwise
/// returns the levels so labelled, each with its share, for a warning.
pub fn check_labels(levels: &LevelMix) -> Result<Vec<String>, RunError> {
    use crate::policy::ppo::TRAIN_SEED_OFFSET;
    let seeds = TRAIN_SEED_OFFSET..TRAIN_SEED_OFFSET + LABEL_CHECK_EPISODES;
    let mut silent = Vec::new();
    for e in levels.entries() {
        let share = crate::bot::label_share(&e.level, seeds.clone())
            .map_err(|err| RunError::invalid("imitate", err))?;
        if share.share() < LABEL_SHARE_MIN {
            silent.push(format!(
                "{} ({} of {} steps labelled; the bot gave up on {} of {} episodes)",
                e.level.id(),
                share.labelled,
                share.steps,
                share.gave_up,
                share.episodes
            ));
        }
    }
    if silent.len() == levels.entries().len() {
        return Err(RunError::invalid(
            "imitate",
            format!(
                "the bot labels almost nothing of {}: imitation would learn from no labelled frame",
                silent.join("; ")
            ),
        ));
    }
    Ok(silent)
}

/// Loads `--teacher`'s networks, in order, refusing what cannot teach `levels`: what
/// [`Parent::load`] refuses (the bot, an ONNX graph, a file that does not load), a teacher
/// for a level outside the mix or two for one level ([`crate::policy::ppo::teacher_of`]),
/// and one that lacks a word of the missions it is to read ([`Parent::check_words`]).
pub fn load_teachers(
    specs: &[TeacherSpec],
    levels: &LevelMix,
) -> Result<Vec<(ModelConfig, Params)>, RunError> {
    let of_entry = crate::policy::ppo::teacher_of(specs, levels)
        .map_err(|e| RunError::invalid("teacher", e))?;
    let mut nets = Vec::with_capacity(specs.len());
    for (t, spec) in specs.iter().enumerate() {
        let teacher = Parent::load(&spec.name).map_err(|e| match e {
            RunError::BotParent => RunError::invalid(
                "teacher",
                format!(
                    "{}: the bot already labels imitation's frames where it can; name a trained checkpoint",
                    spec.name
                ),
            ),
            other => other,
        })?;
        let taught: Vec<MixEntry> = levels
            .entries()
            .iter()
            .zip(&of_entry)
            .filter(|(_, o)| **o == Some(t))
            .map(|(e, _)| *e)
            .collect();
        if taught.is_empty() {
            return Err(RunError::invalid(
                "teacher",
                format!("{spec}: teaches none of the levels (each is named by another teacher)"),
            ));
        }
        let taught = LevelMix::new(taught).map_err(|e| RunError::invalid("teacher", e))?;
        teacher.check_words(&taught).map_err(|e| match e {
            RunError::Invalid { reason, .. } => {
                RunError::invalid("teacher", format!("{}: {reason}", spec.name))
            }
            other => other,
        })?;
        let ckpt = teacher.checkpoint;
        nets.push((ckpt.meta.model, ckpt.params));
    }
    Ok(nets)
}

/// `specs` with every file name made absolute (from the working directory), so that a resume
/// from anywhere loads the same teachers; bundled names stay as they are.
pub fn absolute_teachers(specs: &[TeacherSpec]) -> Result<Vec<TeacherSpec>, RunError> {
    specs
        .iter()
        .map(|s| {
            if s.name.starts_with(crate::policy::bundled::PREFIX) {
                return Ok(s.clone());
            }
            let path = std::path::absolute(&s.name)
                .map_err(RunError::io(format!("resolving --teacher {}", s.name)))?;
            Ok(TeacherSpec {
                level: s.level,
                name: path.display().to_string(),
            })
        })
        .collect()
}
