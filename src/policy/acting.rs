//! What the episode runner needs of a policy, so that a native network and an imported ONNX
//! graph run the same episodes through the same code (`episode::run_from` and friends).

use candle_core::{DType, Device, Tensor};

use super::attention::Intervention;
use super::config::Variant;
use super::error::PolicyError;
use super::model::{Memory, MissionInputs, Net};
use super::{ActOptions, ActOutput, episode_mission};
use crate::env::view::Observation;

/// The first word of `tokens` the policy does not know: past a native model's trained rows,
/// or missing from an imported graph's vocabulary.
pub fn unknown_word<P: Acting + ?Sized>(policy: &P, tokens: &[u32]) -> Option<u32> {
    let known = policy.known_words();
    if let Some(&t) = tokens.iter().find(|&&t| t as usize >= known) {
        return Some(t);
    }
    let ids = policy.input_token_ids(tokens)?;
    tokens
        .iter()
        .zip(ids)
        .find(|(_, id)| *id < 0)
        .map(|(t, _)| *t)
}

/// The token ids of `mission` for `policy`: BabyAI's split into groundscope's vocabulary
/// ([`crate::env::vocab::tokenize_on_level`]), then [`check_known_words`]; either refusal
/// names the word, the mission and `level`.
pub fn mission_tokens<P: Acting + ?Sized>(
    policy: &P,
    mission: &str,
    level: impl Fn() -> String,
) -> Result<Vec<u32>, PolicyError> {
    let tokens = crate::env::vocab::tokenize_on_level(mission, &level)?;
    check_known_words(policy, &tokens, mission, level)?;
    Ok(tokens)
}

/// [`mission_tokens`] of the mission `world` starts with, after refusing minigrid's bot on one
/// of MiniGrid's own environments (it plans BabyAI instructions only).
pub fn world_tokens<P: Acting + ?Sized>(
    policy: &P,
    world: &crate::env::World,
    level: impl Fn() -> String,
) -> Result<Vec<u32>, PolicyError> {
    if policy.reads_world() && world.rules.is_some() {
        return Err(PolicyError::Input(format!(
            "--checkpoint bot on {}: BabyAI's bot plans BabyAI instructions only, and this is \
             one of MiniGrid's own environments (its mission is not a BabyAI instruction)",
            level()
        )));
    }
    mission_tokens(policy, &world.mission, level)
}

/// Refuses a mission with a word the policy does not know (a native model's untrained or
/// missing embedding row, a word an imported graph's vocabulary lacks), naming the word, the
/// mission and `level`.
pub fn check_known_words<P: Acting + ?Sized>(
    policy: &P,
    tokens: &[u32],
    mission: &str,
    level: impl FnOnce() -> String,
) -> Result<(), PolicyError> {
    let Some(t) = unknown_word(policy, tokens) else {
        return Ok(());
    };
    let known = policy.known_words();
    let why = if (t as usize) < known {
        format!(
            "is not in the graph's vocabulary (metadata groundscope.vocabulary; it knows {})",
            known_word_list(policy).join(", ")
        )
    } else if t as usize >= crate::env::vocab::BABYAI_VOCAB_SIZE {
        format!(
            "is one of MiniGrid's own missions' words, and this model knows {} words only \
             (BabyAI's at most); `--checkpoint bundled:minigrid` reads every MiniGrid id, \
             `groundscope init --level ID` makes a model with rows for all {}, \
             `groundscope train --level ID` trains one",
            known - 1,
            crate::env::vocab::VOCAB_SIZE - 1
        )
    } else {
        format!(
            "is not one this model was trained on: it knows the paper's {} words (a model of \
             the paper's level); use `--checkpoint bundled:babyai`, which reads every BabyAI level, or \
             train one on a BabyAI level (`train --level ID`)",
            known - 1
        )
    };
    Err(PolicyError::Input(format!(
        "mission word {:?} in mission {} of level {} {why}",
        crate::env::vocab::word(t).unwrap_or("?"),
        crate::env::error::shown(mission),
        level(),
    )))
}

/// The words of groundscope's vocabulary `policy` can read, in vocabulary order.
pub fn known_word_list<P: Acting + ?Sized>(policy: &P) -> Vec<&'static str> {
    let known = policy.known_words();
    (1..crate::env::vocab::VOCAB_SIZE as u32)
        .filter(|&t| (t as usize) < known)
        .filter(|&t| {
            policy
                .input_token_ids(&[t])
                .is_none_or(|ids| ids.first().is_some_and(|&i| i >= 0))
        })
        .filter_map(crate::env::vocab::word)
        .collect()
}

/// One step's whole input for B environments, as every [`Acting`] policy reads it.
#[derive(Clone, Copy)]
pub struct Step<'a> {
    /// Each environment's observation.
    pub obs: &'a [Observation],
    /// Each agent's direction (0–3).
    pub directions: &'a [u8],
    /// Each environment's mission tokens.
    pub missions: &'a [&'a [u32]],
    /// Which of the caller's episodes each row is (the caller's numbering: `0..B` where the
    /// batch is all of them, the running ones' indices as episodes end): what a policy that
    /// keeps state of its own per episode (a Python policy) reads.
    pub rows: &'a [usize],
    /// What [`Acting::prepare`] / [`Acting::prepare_batch`] returned, these rows of it
    /// (`select`ed); `None` to compute it.
    pub prepared: Option<&'a MissionInputs>,
    /// The memory before the step, a row per environment.
    pub memory: &'a Memory,
    /// Whether to return the attention traces.
    pub traces: bool,
    /// An intervention on the attention ([`Acting::takes_interventions`]).
    pub intervention: Option<&'a Intervention>,
}

/// The rows `0..n`, for [`Step::rows`] of a batch that is all of the caller's episodes.
pub fn all_rows(n: usize) -> Vec<usize> {
    (0..n).collect()
}

impl<'a> Step<'a> {
    /// The step of one episode (its row 0) with nothing prepared, no traces and no
    /// intervention; set the fields to add them.
    pub fn one(
        obs: &'a Observation,
        direction: &'a u8,
        tokens: &'a &'a [u32],
        memory: &'a Memory,
    ) -> Self {
        Self {
            obs: std::slice::from_ref(obs),
            directions: std::slice::from_ref(direction),
            missions: std::slice::from_ref(tokens),
            rows: &[0],
            prepared: None,
            memory,
            traces: false,
            intervention: None,
        }
    }
}

/// A policy that acts in one environment at a time.
pub trait Acting {
    /// Attention (the traces carry maps) or baseline (they do not).
    fn variant(&self) -> Variant;

    /// How many entries of groundscope's vocabulary (padding included) the policy was trained
    /// on: a native model's `vocab_size`; an imported graph maps its own vocabulary and
    /// names a missing word itself, so every entry.
    fn known_words(&self) -> usize {
        crate::env::vocab::VOCAB_SIZE
    }

    /// The memory of a fresh episode.
    fn zero_memory(&self) -> Result<Memory, PolicyError>;

    /// Whatever depends only on the mission, computed once per episode (`None` where the
    /// policy has nothing to keep).
    fn prepare(&self, tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError>;

    /// One step of the B environments of `step` (B = 1 for an episode's step).
    fn act_step(&self, step: &Step<'_>) -> Result<ActOutput, PolicyError>;

    /// The memory of B fresh episodes.
    fn zero_memory_batch(&self, batch: usize) -> Result<Memory, PolicyError>;

    /// [`Self::prepare`] for B missions at once (the rows are later `select`ed).
    fn prepare_batch(&self, missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError>;

    /// Whether [`Intervention`]s on the attention can be applied (a native attention network;
    /// an imported graph with maps that takes the override inputs of docs/onnx.md).
    fn takes_interventions(&self) -> bool;

    /// How many actions the policy scores: MiniGrid's first `n` (left, right, forward, pickup,
    /// drop, toggle, done). Seven but for an imported graph trained on the first three, as
    /// Dynamic-Obstacles' and many lava agents are; displays show that many, never empty bars.
    fn n_actions(&self) -> usize {
        crate::env::Action::COUNT
    }

    /// The name the model gives itself, where it has one beside its file name: an imported
    /// graph's `groundscope.name` metadata.
    fn model_name(&self) -> Option<String> {
        None
    }

    /// The mission's token ids as the policy receives them, where they are not groundscope's
    /// own: an imported graph's, numbered by its `groundscope.vocabulary`.
    fn input_token_ids(&self, _tokens: &[u32]) -> Option<Vec<i64>> {
        None
    }

    /// Whether the policy is minigrid's bot ([`BotAgent`]), which reads the world rather than
    /// the observation: episode runners then act with the expert they keep beside every
    /// episode ([`crate::bot::Expert`]) and never call the `act_*` methods.
    fn reads_world(&self) -> bool {
        false
    }

    /// The step of a policy that [`Self::reads_world`]: the expert's `advice` for each row
    /// as the policy's output ([`bot_output`]).
    fn act_from_expert(
        &self,
        advice: &[Option<crate::env::Action>],
    ) -> Result<ActOutput, PolicyError> {
        bot_output(advice)
    }
}

/// minigrid's BabyAI bot as an agent (`--checkpoint bot`): no network, no maps, no memory;
/// it acts from the world itself ([`Acting::reads_world`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct BotAgent;

/// What the bot "outputs" for a batch of steps: all probability on each row's action (`done`
/// where it gave up), value 0, no memory, no maps.
pub fn bot_output(actions: &[Option<crate::env::Action>]) -> Result<ActOutput, PolicyError> {
    let probs: Vec<Vec<f32>> = actions
        .iter()
        .map(|a| {
            let mut p = vec![0.0; crate::env::Action::COUNT];
            p[a.unwrap_or(crate::env::Action::Done) as usize] = 1.0;
            p
        })
        .collect();
    Ok(ActOutput {
        logits: probs
            .iter()
            .map(|p| {
                p.iter()
                    .map(|&x| if x > 0.0 { 0.0 } else { -1e9 })
                    .collect()
            })
            .collect(),
        probs,
        values: vec![0.0; actions.len()],
        memory: flat_memory_rows(Vec::new(), actions.len())?,
        traces: None,
    })
}

fn bot_reads_the_world() -> PolicyError {
    PolicyError::Input(
        "the bot acts from the world, not from an observation: it has no network to probe".into(),
    )
}

impl Acting for BotAgent {
    fn variant(&self) -> Variant {
        Variant::Baseline
    }

    fn zero_memory(&self) -> Result<Memory, PolicyError> {
        flat_memory(Vec::new())
    }

    fn prepare(&self, _tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError> {
        Ok(None)
    }

    fn act_step(&self, _step: &Step<'_>) -> Result<ActOutput, PolicyError> {
        Err(bot_reads_the_world())
    }

    fn zero_memory_batch(&self, batch: usize) -> Result<Memory, PolicyError> {
        flat_memory_rows(Vec::new(), batch)
    }

    fn prepare_batch(&self, _missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError> {
        Ok(None)
    }

    fn takes_interventions(&self) -> bool {
        false
    }

    fn model_name(&self) -> Option<String> {
        Some("minigrid's BabyAI bot".into())
    }

    fn reads_world(&self) -> bool {
        true
    }
}

impl Acting for Net {
    fn variant(&self) -> Variant {
        self.cfg.variant
    }

    fn known_words(&self) -> usize {
        self.cfg.vocab_size
    }

    fn zero_memory_batch(&self, batch: usize) -> Result<Memory, PolicyError> {
        Memory::zeros(batch, self.cfg.lstm_hidden)
    }

    fn prepare_batch(&self, missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError> {
        self.mission_inputs(&super::TokenBatch::new(missions)?)
            .map(Some)
    }

    fn act_step(&self, step: &Step<'_>) -> Result<ActOutput, PolicyError> {
        super::act(
            self,
            step.obs,
            step.missions,
            step.memory,
            ActOptions {
                traces: step.traces,
                intervention: step.intervention,
                prepared: step.prepared,
            },
        )
    }

    fn takes_interventions(&self) -> bool {
        self.cfg.has_attention()
    }

    fn zero_memory(&self) -> Result<Memory, PolicyError> {
        Memory::zeros(1, self.cfg.lstm_hidden)
    }

    fn prepare(&self, tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError> {
        episode_mission(self, tokens).map(Some)
    }
}

/// An imported graph's memory in [`Memory`]'s shape: `h` holds the graph's M values, `c` is
/// empty.
pub fn flat_memory(values: Vec<f32>) -> Result<Memory, PolicyError> {
    flat_memory_rows(values, 1)
}

/// [`flat_memory`] for `rows` environments (`values` row-major).
pub fn flat_memory_rows(values: Vec<f32>, rows: usize) -> Result<Memory, PolicyError> {
    let m = values.len() / rows.max(1);
    Ok(Memory {
        h: Tensor::from_vec(values, (rows, m), &Device::Cpu)?,
        c: Tensor::zeros((rows, 0), DType::F32, &Device::Cpu)?,
    })
}

/// Softmax of one row of logits, on the host.
pub fn softmax(logits: &[f32]) -> Vec<f32> {
    let max = logits.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b));
    let e: Vec<f32> = logits.iter().map(|&x| (x - max).exp()).collect();
    let z: f32 = e.iter().sum();
    e.into_iter().map(|x| x / z).collect()
}

/// A policy loaded from the command line: a native checkpoint's network or an ONNX graph.
#[derive(Debug)]
pub enum Agent {
    /// A groundscope checkpoint.
    Native(Box<super::Checkpoint>, Box<Net>),
    /// An imported graph (docs/onnx.md).
    Onnx(Box<super::onnx::OnnxAgent>),
    /// minigrid's BabyAI bot (`--checkpoint bot`, docs/bot.md).
    Bot(BotAgent),
}

/// The `--checkpoint` value that names the bot.
pub const BOT: &str = "bot";

impl Agent {
    /// Loads `spec`: a file ending in `.onnx` as an imported graph, anything else as
    /// [`super::bundled::load`] does (a checkpoint name, a run directory, `bundled:NAME`).
    pub fn load(spec: &str) -> Result<Self, PolicyError> {
        if spec == BOT {
            return Ok(Self::Bot(BotAgent));
        }
        if super::onnx::is_onnx(std::path::Path::new(spec)) {
            return Ok(Self::Onnx(Box::new(super::onnx::OnnxAgent::load(
                std::path::Path::new(spec),
            )?)));
        }
        let ckpt = super::bundled::load(spec)?;
        let net = Net::new(ckpt.meta.model, ckpt.params.detached())?;
        Ok(Self::Native(Box::new(ckpt), Box::new(net)))
    }

    /// The level it was trained on (the bot: the paper's level, as a default).
    pub fn level(&self) -> crate::env::LevelConfig {
        match self {
            Self::Native(ckpt, _) => ckpt.meta.level,
            Self::Onnx(a) => a.meta.level,
            Self::Bot(_) => crate::env::LevelConfig::default(),
        }
    }

    /// The policy, to run episodes with.
    pub fn acting(&self) -> &(dyn Acting + Send + Sync) {
        match self {
            Self::Native(_, net) => &**net,
            Self::Onnx(a) => a.as_ref(),
            Self::Bot(b) => b,
        }
    }

    /// Frames it was trained for (`None` for an imported graph, whose metadata does not say,
    /// and for the bot, which is not trained).
    pub fn frames(&self) -> Option<u64> {
        match self {
            Self::Native(ckpt, _) => Some(ckpt.meta.training.frames),
            Self::Onnx(_) | Self::Bot(_) => None,
        }
    }

    /// The weight of `train --ground-loss` its maps were supervised with, if they were.
    pub fn ground_loss(&self) -> Option<f64> {
        match self {
            Self::Native(ckpt, _) => ckpt.meta.training.ground_loss,
            Self::Onnx(_) | Self::Bot(_) => None,
        }
    }

    /// The level it was trained on, where there is one (not the bot's).
    pub fn trained_level(&self) -> Option<crate::env::LevelConfig> {
        match self {
            Self::Bot(_) => None,
            _ => Some(self.level()),
        }
    }

    /// The name a report gives its kind: attention, baseline, or bot.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Self::Bot(_) => "bot",
            _ => self.acting().variant().name(),
        }
    }
}
