//! The serialisable model configuration: every size of the network.

use crate::env::vocab::{BABYAI_VOCAB_SIZE, PAPER_VOCAB_SIZE, VOCAB_SIZE};
use serde::{Deserialize, Serialize};

/// Which network: the paper's text-visual attention policy or its no-attention baseline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Variant {
    /// Per-word attention maps over the view (paper §3.3).
    Attention,
    /// The same network with `Õ` going straight into the LSTM.
    Baseline,
}

impl Variant {
    /// Parses `attention` or `baseline`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "attention" => Some(Self::Attention),
            "baseline" => Some(Self::Baseline),
            _ => None,
        }
    }

    /// The lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Attention => "attention",
            Self::Baseline => "baseline",
        }
    }
}

/// Which cells the encoder's colour one-hot is set on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ColourCodes {
    /// Every cell, as MiniGrid encodes it (the default): empty and unseen cells carry colour 0,
    /// red, and walls grey, so those two colours' codes are set all over the view.
    #[default]
    All,
    /// Only cells holding an object with a colour: unseen, empty and wall cells keep their type
    /// and state codes, so every colour's code picks out objects of that colour.
    Objects,
    /// Walls and objects: only unseen and empty cells lose their colour code (MiniGrid's red),
    /// so red marks red objects alone while walls still read grey.
    #[serde(rename = "walls-objects")]
    WallsObjects,
}

impl ColourCodes {
    /// The lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Self::All => "all",
            Self::Objects => "objects",
            Self::WallsObjects => "walls-objects",
        }
    }

    /// Parses `all`, `objects` or `walls-objects`, naming the setting otherwise.
    pub fn parse(s: &str) -> Result<Self, super::PolicyError> {
        match s {
            "all" => Ok(Self::All),
            "objects" => Ok(Self::Objects),
            "walls-objects" => Ok(Self::WallsObjects),
            _ => Err(super::PolicyError::Input(format!(
                "model setting colour_codes = {s} must be all, objects or walls-objects"
            ))),
        }
    }

    /// Whether it is the default (checkpoints leave the default out).
    #[expect(
        clippy::trivially_copy_pass_by_ref,
        reason = "serde's skip_serializing_if passes a reference"
    )]
    fn is_all(&self) -> bool {
        *self == Self::All
    }
}

/// Which mission words the attention weighs: every word gets a map either way, and the GRU
/// reads the whole mission; this decides which maps enter `w`, `M` and the filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AttendWords {
    /// Every word of the mission (the paper's eqs. 5–6, the default).
    #[default]
    All,
    /// The object and colour words only ([`is_content_word`]), so `M` is made of the maps of
    /// the words that name the target (the big-room study's part 3). A mission without such
    /// a word keeps all its words.
    Content,
}

impl AttendWords {
    /// The lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Self::All => "all",
            Self::Content => "content",
        }
    }

    /// Parses `all` or `content`, naming the setting otherwise.
    pub fn parse(s: &str) -> Result<Self, super::PolicyError> {
        match s {
            "all" => Ok(Self::All),
            "content" => Ok(Self::Content),
            _ => Err(super::PolicyError::Input(format!(
                "model setting attend_words = {s} must be all or content"
            ))),
        }
    }

    /// Whether it is the default (checkpoints leave the default out).
    #[expect(
        clippy::trivially_copy_pass_by_ref,
        reason = "serde's skip_serializing_if passes a reference"
    )]
    fn is_all(&self) -> bool {
        *self == Self::All
    }

    /// The attention's word mask of one mission: 1 for each word it weighs, 0 for the rest
    /// (the padding's 0s are the caller's).
    pub fn mask(self, tokens: &[u32]) -> Vec<f32> {
        let content = |t: &u32| is_content_word(*t);
        match self {
            Self::Content if tokens.iter().any(content) => tokens
                .iter()
                .map(|t| f32::from(u8::from(content(t))))
                .collect(),
            _ => vec![1.0; tokens.len()],
        }
    }
}

/// Whether token `id` names an object type or a colour: the nine words the grounding metrics
/// score (key, ball, box and the six colours).
pub fn is_content_word(id: u32) -> bool {
    matches!(
        crate::env::vocab::word(id),
        Some("key" | "ball" | "box" | "red" | "green" | "blue" | "purple" | "yellow" | "grey")
    )
}

/// The word weights' temperature `T` in `w = softmax(−H / T)`: 1 is the paper's eq. 5; a
/// larger `T` weighs the words more evenly, so a flat map keeps some weight in `M` (and some
/// gradient). Compared and hashed by its bits; [`ModelConfig::validate`] keeps it in
/// [`Self::MIN`, `Self::MAX`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct WordTemperature(pub f32);

impl WordTemperature {
    /// The paper's eq. 5.
    pub const PAPER: Self = Self(1.0);
    /// The largest temperature accepted: past it every weight is within 4% of uniform.
    pub const MAX: f32 = 100.0;
    /// The smallest temperature accepted: `H / T` stays far from f32's overflow (entropies are
    /// at most ln 49), and the weights are already one-hot to f32's precision.
    pub const MIN: f32 = 0.01;

    /// Whether it is the paper's (checkpoints leave it out).
    #[expect(
        clippy::trivially_copy_pass_by_ref,
        reason = "serde's skip_serializing_if passes a reference"
    )]
    fn is_paper(&self) -> bool {
        *self == Self::PAPER
    }
}

impl Default for WordTemperature {
    fn default() -> Self {
        Self::PAPER
    }
}

// Validation admits finite values only, so equality by value is total.
impl Eq for WordTemperature {}

impl std::hash::Hash for WordTemperature {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.to_bits().hash(state);
    }
}

/// Sizes of the network (DESIGN.md §1 defaults).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[expect(
    clippy::struct_excessive_bools,
    reason = "independent model options, each a field of the checkpoint's JSON"
)]
pub struct ModelConfig {
    /// Attention or baseline.
    pub variant: Variant,
    /// K: channels of the convolution that keeps the 7×7 grid.
    pub conv_channels: usize,
    /// Side of the convolution's kernel: 3 (the default, DESIGN.md §1) or 1. With 3 every
    /// cell's features carry its eight neighbours' codes, so a word map one cell beside its
    /// object passes the object to the LSTM as well as a map on it; with 1 a cell's features
    /// are its own codes only. Checkpoints without the field have 3, and 3 is not written,
    /// so their files stay as they were.
    #[serde(
        default = "ModelConfig::default_kernel",
        skip_serializing_if = "ModelConfig::is_default_kernel"
    )]
    pub conv_kernel: usize,
    /// The filter's factor `s` in `F_j = s · M_j · Õ_j`: 49 (the default, ours: a uniform `M`
    /// passes `Õ` unchanged) or 1 (the paper's `F = Õ · M`: a flat `M` shrinks every input,
    /// so sharp maps pay). Written to checkpoints only when it is not 49.
    #[serde(
        default = "ModelConfig::default_filter_scale",
        skip_serializing_if = "ModelConfig::is_default_filter_scale"
    )]
    pub filter_scale: u32,
    /// Which cells carry a colour code ([`ColourCodes`]). Written only when not `all`.
    #[serde(default, skip_serializing_if = "ColourCodes::is_all")]
    pub colour_codes: ColourCodes,
    /// The word weights' temperature ([`WordTemperature`]). Written only when not 1.
    #[serde(default, skip_serializing_if = "WordTemperature::is_paper")]
    pub word_temperature: WordTemperature,
    /// Which words the attention weighs ([`AttendWords`]). Written only when not `all`.
    #[serde(default, skip_serializing_if = "AttendWords::is_all")]
    pub attend_words: AttendWords,
    /// Where the attention's keys come from: `None` (the paper's, and the default) from `Õ`,
    /// the same features the filter passes; `Some(side)` from a second encoder of their own
    /// with that kernel side (1 or 3, K channels, `encoder.key_conv.*`), so the maps can be
    /// drawn from each cell's own codes while the filter passes features that carry the
    /// neighbours (the big-room study's split keys). Attention only; written only when set.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key_kernel: Option<usize>,
    /// A learned query of no word (`attention.search.weight`, the big-room study's part 5):
    /// its map `S` over the same keys is the search's own channel, and the LSTM reads
    /// `[s · M ⊙ Õ | s · S ⊙ Õ]`. `w` and `M` are unchanged by it. Attention only, not with
    /// split keys; written only when set.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub search_query: bool,
    /// A learned key of no cell (`attention.null.weight`, the big-room study's part 9): it
    /// joins every word's softmax as a 50th entry and its share is spread evenly over the 49
    /// cells ([`super::attention::attention_maps_null`]), so a word can make its map flat
    /// when nothing it names is in view. Attention only, not with the search query; written
    /// only when set.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub null_key: bool,
    /// With split keys ([`Self::key_kernel`]): the keys read the split keys' own features and
    /// the filter's features together, `Kc = [Õ_key | Õ] W_k` with `W_k` (d_k × 2K), so a map
    /// has both a cell's own codes and its neighbourhood to point by (the big-room study's
    /// part 11). Not with the null key; written only when set.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub key_context: bool,
    /// An unattended path for the layout (issue #64): a second encoder (`layout.conv.*`, K
    /// channels, the encoder's kernel) over the cells' codes with every object's type and
    /// colour and every door's colour removed ([`super::obs::CellCodes::layout`]), whose
    /// features `L` reach the LSTM beside the filter's, `[F | L]`. Walls, doors and their
    /// states, and where something stands, pass whatever `M` marks, so `M` is free to mark the
    /// referents; which object or door is which still passes through `M` alone. Attention
    /// only; written only when set.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub layout_path: bool,
    /// Keep the LSTM's input at the view's scale however sharp `M` is (issue #64): the
    /// filter's features rescaled per frame to the norm of the features they filter,
    /// `F' = F · ‖Õ‖ / ‖F‖` (norms over the 49·K entries). A uniform `M` leaves `F` as it was
    /// (`F = Õ` at the default factor 49); a map on one cell no longer passes that cell's
    /// features at up to 49 times the scale the LSTM read under flat maps. With the search
    /// query its filtered copy is rescaled the same way, on its own. Attention only; no
    /// weights, so `train --init` may add it. Written only when set.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub filter_norm: bool,
    /// How many entries of groundscope's vocabulary the word embedding has rows for, padding
    /// included: [`PAPER_VOCAB_SIZE`] (the paper's 25 words; what a model trained on the paper's
    /// level has, and every checkpoint made before BabyAI's whole grammar was added) or
    /// [`BABYAI_VOCAB_SIZE`] (all of BabyAI's words: a model trained on a BabyAI level) or
    /// [`VOCAB_SIZE`] (MiniGrid's words too: a model trained on its environments). A mission
    /// word past the rows is refused by name, never embedded with an untrained row. Written
    /// only when not the paper's.
    #[serde(
        default = "ModelConfig::paper_vocab_size",
        skip_serializing_if = "ModelConfig::is_paper_vocab_size"
    )]
    pub vocab_size: usize,
    /// E: word embedding size.
    pub word_dim: usize,
    /// d_k: query/key size.
    pub key_dim: usize,
    /// Hidden size of the LSTM over the (filtered) visual features.
    pub lstm_hidden: usize,
    /// Hidden size of the GRU over the mission words.
    pub gru_hidden: usize,
    /// Hidden units of the tanh layer in the actor and in the critic.
    pub head_hidden: usize,
}

impl ModelConfig {
    /// The DESIGN.md defaults for `variant`: K = 16, E = 32, d_k = 32, LSTM/GRU 128, heads 64.
    pub fn new(variant: Variant) -> Self {
        Self {
            variant,
            conv_channels: 16,
            conv_kernel: Self::DEFAULT_KERNEL,
            filter_scale: Self::DEFAULT_FILTER_SCALE,
            colour_codes: ColourCodes::All,
            word_temperature: WordTemperature::PAPER,
            key_kernel: None,
            attend_words: AttendWords::All,
            search_query: false,
            null_key: false,
            key_context: false,
            layout_path: false,
            filter_norm: false,
            vocab_size: PAPER_VOCAB_SIZE,
            word_dim: 32,
            key_dim: 32,
            lstm_hidden: 128,
            gru_hidden: 128,
            head_hidden: 64,
        }
    }

    /// The paper's (and DESIGN.md's) kernel side.
    pub const DEFAULT_KERNEL: usize = 3;
    /// The kernel sides the encoder supports.
    pub const KERNELS: [usize; 2] = [1, 3];

    /// The default filter factor (the number of view cells).
    pub const DEFAULT_FILTER_SCALE: u32 = 49;
    /// The filter factors the model supports.
    pub const FILTER_SCALES: [u32; 2] = [1, 49];

    fn default_filter_scale() -> u32 {
        Self::DEFAULT_FILTER_SCALE
    }

    #[expect(
        clippy::trivially_copy_pass_by_ref,
        reason = "serde's skip_serializing_if passes a reference"
    )]
    fn is_default_filter_scale(s: &u32) -> bool {
        *s == Self::DEFAULT_FILTER_SCALE
    }

    fn paper_vocab_size() -> usize {
        PAPER_VOCAB_SIZE
    }

    #[expect(
        clippy::trivially_copy_pass_by_ref,
        reason = "serde's skip_serializing_if passes a reference"
    )]
    fn is_paper_vocab_size(n: &usize) -> bool {
        *n == PAPER_VOCAB_SIZE
    }

    /// The vocabulary a model trained on `level` needs: the paper's words on the paper's
    /// level, all of BabyAI's on a registered BabyAI level, MiniGrid's too on one of its
    /// environments.
    pub fn vocab_size_for(level: &crate::env::level::LevelConfig) -> usize {
        match level.babyai {
            Some(id) if id.minigrid().is_some() => VOCAB_SIZE,
            Some(_) => BABYAI_VOCAB_SIZE,
            None => PAPER_VOCAB_SIZE,
        }
    }

    fn default_kernel() -> usize {
        Self::DEFAULT_KERNEL
    }

    #[expect(
        clippy::trivially_copy_pass_by_ref,
        reason = "serde's skip_serializing_if passes a reference"
    )]
    fn is_default_kernel(k: &usize) -> bool {
        *k == Self::DEFAULT_KERNEL
    }

    /// The largest size accepted for any dimension: well past the paper's (128) and small
    /// enough that a network always fits in memory (an LSTM of 1,024 over 49·256 inputs is
    /// about 55M parameters).
    pub const MAX_SIZE: usize = 1024;
    /// The largest number of convolution channels (the LSTM input is 49 times this).
    pub const MAX_CHANNELS: usize = 256;

    /// Checks every size is positive and bounded, naming the field.
    pub fn validate(&self) -> Result<(), super::PolicyError> {
        let t = self.word_temperature.0;
        if !(t.is_finite() && (WordTemperature::MIN..=WordTemperature::MAX).contains(&t)) {
            return Err(super::PolicyError::Input(format!(
                "model setting word_temperature = {t:?} must be in [{}, {}]",
                WordTemperature::MIN,
                WordTemperature::MAX
            )));
        }
        if !Self::FILTER_SCALES.contains(&self.filter_scale) {
            return Err(super::PolicyError::Input(format!(
                "model setting filter_scale = {} must be 1 or 49",
                self.filter_scale
            )));
        }
        if let Some(k) = self.key_kernel {
            if !Self::KERNELS.contains(&k) {
                return Err(super::PolicyError::Input(format!(
                    "model setting key_kernel = {k} must be 1 or 3"
                )));
            }
            if !self.has_attention() {
                return Err(super::PolicyError::Input(
                    "model setting key_kernel is for the attention model only".into(),
                ));
            }
        }
        if self.search_query && (!self.has_attention() || self.key_kernel.is_some()) {
            return Err(super::PolicyError::Input(
                "model setting search_query is for the attention model with shared keys only"
                    .into(),
            ));
        }
        if self.null_key && (!self.has_attention() || self.search_query) {
            return Err(super::PolicyError::Input(
                "model setting null_key is for the attention model without search_query only"
                    .into(),
            ));
        }
        if self.key_context && (self.key_kernel.is_none() || self.null_key) {
            return Err(super::PolicyError::Input(
                "model setting key_context needs split keys (key_kernel) and no null_key".into(),
            ));
        }
        if self.layout_path && !self.has_attention() {
            return Err(super::PolicyError::Input(
                "model setting layout_path is for the attention model only (the baseline's \
                 LSTM already reads the whole view)"
                    .into(),
            ));
        }
        if self.filter_norm && !self.has_attention() {
            return Err(super::PolicyError::Input(
                "model setting filter_norm is for the attention model only (the baseline has no \
                 filter)"
                    .into(),
            ));
        }
        if self.attend_words != AttendWords::All && !self.has_attention() {
            return Err(super::PolicyError::Input(
                "model setting attend_words is for the attention model only".into(),
            ));
        }
        if ![PAPER_VOCAB_SIZE, BABYAI_VOCAB_SIZE, VOCAB_SIZE].contains(&self.vocab_size) {
            return Err(super::PolicyError::Input(format!(
                "model setting vocab_size = {} must be {PAPER_VOCAB_SIZE} (the paper's words), \
                 {BABYAI_VOCAB_SIZE} (BabyAI's) or {VOCAB_SIZE} (MiniGrid's too)",
                self.vocab_size
            )));
        }
        if !Self::KERNELS.contains(&self.conv_kernel) {
            return Err(super::PolicyError::Input(format!(
                "model size conv_kernel = {} must be 1 or 3",
                self.conv_kernel
            )));
        }
        for (name, v, max) in [
            ("conv_channels", self.conv_channels, Self::MAX_CHANNELS),
            ("word_dim", self.word_dim, Self::MAX_SIZE),
            ("key_dim", self.key_dim, Self::MAX_SIZE),
            ("lstm_hidden", self.lstm_hidden, Self::MAX_SIZE),
            ("gru_hidden", self.gru_hidden, Self::MAX_SIZE),
            ("head_hidden", self.head_hidden, Self::MAX_SIZE),
        ] {
            if v == 0 || v > max {
                return Err(super::PolicyError::Input(format!(
                    "model size {name} = {v} must be in 1..={max}"
                )));
            }
        }
        Ok(())
    }

    /// Whether the network has the attention module.
    pub fn has_attention(&self) -> bool {
        self.variant == Variant::Attention
    }

    /// Width of the LSTM's input: `49·K` for the filter's features, and `49·K` more for each
    /// of the [`Self::search_query`]'s and the [`Self::layout_path`]'s.
    pub fn lstm_input_size(&self) -> usize {
        self.filter_input_size() + 49 * self.conv_channels * usize::from(self.layout_path)
    }

    /// Width of what the attention passes the LSTM: `49·K`, twice that with the
    /// [`Self::search_query`]; the [`Self::layout_path`]'s features follow these columns.
    pub fn filter_input_size(&self) -> usize {
        49 * self.conv_channels * (1 + usize::from(self.search_query))
    }
}

#[cfg(test)]
mod tests;
