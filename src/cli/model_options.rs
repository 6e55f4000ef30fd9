//! The model options `train` and `policy init` share: choices about the network beyond its
//! sizes, kept in the checkpoint. One place lists them, so a new one is checked on `--resume`
//! and `--init` like the others.

use clap::Args;
use groundscope::policy::{AttendWords, ColourCodes, ModelConfig, WordTemperature};

/// Model options (defaults: the paper's network as DESIGN.md describes it).
#[derive(Args, Clone, Debug)]
#[expect(
    clippy::struct_excessive_bools,
    reason = "command-line switches, each its own flag"
)]
pub struct ModelOptions {
    /// Side of the encoder's convolution kernel: 3 (the paper's network, DESIGN.md) or 1 (each
    /// cell's features its own codes only, so a word map that helps must cover its object).
    #[arg(long, default_value_t = 3, allow_negative_numbers = true)]
    pub conv_kernel: usize,
    /// The attention filter's factor s in F = s·M·Õ: 49 (uniform attention passes the features
    /// unchanged) or 1 (the paper's F = M·Õ: flat maps shrink every input).
    #[arg(long, default_value_t = 49, allow_negative_numbers = true)]
    pub filter_scale: u32,
    /// Which cells carry a colour code: all (MiniGrid's encoding: empty and unseen cells read
    /// red, walls grey), objects (only cells holding a coloured object) or walls-objects
    /// (walls and objects: only empty and unseen cells lose their red).
    #[arg(long, default_value = "all")]
    pub colour_codes: String,
    /// The word weights' temperature T in w = softmax(−H/T), in [0.01, 100]: 1 is the paper's; a
    /// larger T lets flat word maps keep some weight in M (ln 49 ≈ 3.89: entropy in units of
    /// its maximum).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub word_temperature: f32,
    /// Where the attention's keys come from: shared (the paper's: the encoder's features, the
    /// same ones the filter passes) or 1 / 3 (a second encoder of that kernel side for the
    /// keys alone, so the maps can read each cell's own codes while the filter passes
    /// features that carry the neighbours). Attention model only.
    #[arg(long, default_value = "shared")]
    pub key_kernel: String,
    /// Which mission words the attention weighs in w, M and the filter: all (the paper's) or
    /// content (the object and colour words only; every word still gets its map). Attention
    /// model only.
    #[arg(long, default_value = "all")]
    pub attend_words: String,
    /// Give the search a map of its own: a learned query of no word, whose map S over the same
    /// keys filters a second copy of the features beside M's (the LSTM reads both; w and M are
    /// unchanged). Departs from the paper. Attention model with shared keys only.
    #[arg(long)]
    pub search_query: bool,
    /// Give every word's map a place for "nothing I name is in view": a learned key of no
    /// cell joins each word's softmax and its share is spread evenly over the view (a map
    /// wholly on it is flat, and the filter then passes the whole view). Departs from the
    /// paper. Attention model without --search-query only.
    #[arg(long)]
    pub null_key: bool,
    /// With split keys: let the keys read the filter's features too, `Kc = [Õ_key | Õ] W_k`,
    /// so a map has a cell's own codes and its neighbourhood to point by. Not with
    /// --null-key.
    #[arg(long)]
    pub key_context: bool,
    /// Give the LSTM the layout unattended: a second encoder over the view with objects'
    /// identities and doors' colours removed, read beside the filter's features, so M need
    /// not mark walls and doors to navigate and is free to mark what the words name. With
    /// --init of a model without it, the new weights start at zero (the run starts where its
    /// parent is). Departs from the paper. Attention model only.
    #[arg(long)]
    pub layout_path: bool,
    /// Keep the LSTM's input at the view's scale as M sharpens: the filter's features
    /// rescaled per frame to the norm of the features they filter, F' = F·‖Õ‖/‖F‖ (a uniform
    /// M changes nothing; with --search-query each filtered copy on its own). No weights, so
    /// --init may add it. Departs from the paper. Attention model only.
    #[arg(long)]
    pub filter_norm: bool,
}

/// Parses `--key-kernel`: `shared` or a kernel side (checked by [`ModelConfig::validate`]).
fn parse_key_kernel(s: &str) -> anyhow::Result<Option<usize>> {
    if s == "shared" {
        return Ok(None);
    }
    s.parse()
        .map(Some)
        .map_err(|_| anyhow::anyhow!("--key-kernel {s} must be shared, 1 or 3"))
}

fn key_kernel_name(k: Option<usize>) -> String {
    k.map_or_else(|| "shared".to_owned(), |k| k.to_string())
}

impl ModelOptions {
    /// `cfg` with these options set (checked by [`ModelConfig::validate`]); a colour-code
    /// choice that is not one is an error naming its setting.
    pub fn apply(&self, cfg: ModelConfig) -> anyhow::Result<ModelConfig> {
        Ok(ModelConfig {
            conv_kernel: self.conv_kernel,
            filter_scale: self.filter_scale,
            colour_codes: ColourCodes::parse(&self.colour_codes)?,
            word_temperature: WordTemperature(self.word_temperature),
            key_kernel: parse_key_kernel(&self.key_kernel)?,
            attend_words: AttendWords::parse(&self.attend_words)?,
            search_query: self.search_query,
            null_key: self.null_key,
            key_context: self.key_context,
            layout_path: self.layout_path,
            filter_norm: self.filter_norm,
            ..cfg
        })
    }

    /// Each option as `(clap id, the value given, the value in cfg)`, for comparing a command
    /// line with a checkpoint.
    pub fn against(&self, cfg: &ModelConfig) -> [(&'static str, String, String); 11] {
        [
            (
                "conv_kernel",
                self.conv_kernel.to_string(),
                cfg.conv_kernel.to_string(),
            ),
            (
                "filter_scale",
                self.filter_scale.to_string(),
                cfg.filter_scale.to_string(),
            ),
            (
                "colour_codes",
                self.colour_codes.clone(),
                cfg.colour_codes.name().to_owned(),
            ),
            (
                "word_temperature",
                self.word_temperature.to_string(),
                cfg.word_temperature.0.to_string(),
            ),
            (
                "key_kernel",
                parse_key_kernel(&self.key_kernel)
                    .map_or_else(|_| self.key_kernel.clone(), key_kernel_name),
                key_kernel_name(cfg.key_kernel),
            ),
            (
                "attend_words",
                self.attend_words.clone(),
                cfg.attend_words.name().to_owned(),
            ),
            (
                "search_query",
                self.search_query.to_string(),
                cfg.search_query.to_string(),
            ),
            (
                "null_key",
                self.null_key.to_string(),
                cfg.null_key.to_string(),
            ),
            (
                "key_context",
                self.key_context.to_string(),
                cfg.key_context.to_string(),
            ),
            (
                "layout_path",
                self.layout_path.to_string(),
                cfg.layout_path.to_string(),
            ),
            (
                "filter_norm",
                self.filter_norm.to_string(),
                cfg.filter_norm.to_string(),
            ),
        ]
    }
}
