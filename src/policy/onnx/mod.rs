//! Imported agents: any recurrent policy exported to ONNX under the contract of
//! docs/onnx.md, run by tract (pure Rust) behind the same acting interface as the native
//! model. Built with the `onnx` cargo feature (on by default); without it loading an `.onnx`
//! file is a one-line error.

mod acting;
#[cfg(feature = "onnx")]
pub mod bounds;
#[cfg(feature = "onnx")]
mod clock;
pub mod contract;
#[cfg(feature = "onnx")]
mod load;
#[cfg(feature = "onnx")]
mod maps;
#[cfg(feature = "onnx")]
mod mission_cache;
#[cfg(feature = "onnx")]
mod runtime;

#[cfg(feature = "onnx")]
pub use clock::StepTimes;
#[cfg(feature = "onnx")]
pub use runtime::OnnxAgent;

use crate::policy::trace::ViewMap;

/// What the optional outputs of one row hold, in groundscope's agent-up order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MapOutputs {
    /// One map per mission word (`word_maps`).
    pub words: Option<Vec<ViewMap>>,
    /// One weight per mission word (`word_weights`).
    pub weights: Option<Vec<f32>>,
    /// The combined map (`combined_map`).
    pub combined: Option<ViewMap>,
}

/// One step of an ONNX policy for B environments.
#[derive(Clone, Debug, PartialEq)]
pub struct OnnxStep {
    /// (B, n) action logits: n = 7, or 3 for a graph of left, right and forward only.
    pub logits: Vec<Vec<f32>>,
    /// (B,) values.
    pub values: Vec<f32>,
    /// The new memory, B × M row-major.
    pub memory: Vec<f32>,
    /// Per row, the maps the graph outputs (`None` when it outputs no `word_maps`).
    pub maps: Option<Vec<MapOutputs>>,
}

/// Whether `path` names an ONNX file (by its extension).
pub fn is_onnx(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("onnx"))
}

/// A stand-in for a build without the `onnx` feature: loading says so.
#[cfg(not(feature = "onnx"))]
#[derive(Debug)]
pub struct OnnxAgent {
    /// Never constructed.
    pub meta: contract::Meta,
}

#[cfg(not(feature = "onnx"))]
impl OnnxAgent {
    /// Always an error: this build has no ONNX runtime.
    pub fn load(path: &std::path::Path) -> Result<Self, crate::policy::PolicyError> {
        Err(crate::policy::PolicyError::Input(format!(
            "{}: this groundscope was built without the onnx feature",
            path.display()
        )))
    }
}

/// `M = Σ_i w_i A_i` from word maps and their weights (agent-up).
pub fn combine(words: &[ViewMap], weights: &[f32]) -> ViewMap {
    let mut combined = [[0.0; crate::env::view::VIEW_SIZE]; crate::env::view::VIEW_SIZE];
    for (map, w) in words.iter().zip(weights) {
        for (row, src) in combined.iter_mut().zip(map) {
            for (c, a) in row.iter_mut().zip(src) {
                *c += w * a;
            }
        }
    }
    combined
}

/// `H = −Σ_j A_j ln A_j` in nats, with `0 · ln 0 = 0` as the native model computes it
/// (`attention::entropies`, whose clamp at 1e-30 makes every smaller value's term vanish in
/// f32). Values below 1e-30 are skipped rather than clamped: a sharp softmax leaves most cells
/// subnormal, and arithmetic on subnormals costs this CPU about a hundred cycles a value — it
/// was most of the time an imported graph's traces took (docs/onnx.md#speed).
fn entropy(map: &ViewMap) -> f32 {
    -map.iter()
        .flatten()
        .map(|&a| if a > 1e-30 { a * a.ln() } else { 0.0 })
        .sum::<f32>()
}

/// The attention trace of one step of an imported graph, from the maps it output. The
/// entropies are computed here (`H = −Σ A ln A`, as the native model does); a graph without
/// `word_weights` gets equal weights, and one without `combined_map` gets `M = Σ w A` — both
/// said in docs/onnx.md.
pub fn trace(
    tokens: &[u32],
    maps: &MapOutputs,
) -> Result<crate::policy::AttentionTrace, crate::policy::PolicyError> {
    use crate::policy::{AttentionTrace, WordAttention};
    let words = maps.words.as_deref().unwrap_or_default();
    if words.len() != tokens.len() {
        return Err(crate::policy::PolicyError::Input(format!(
            "output word_maps has {} maps for a mission of {} words",
            words.len(),
            tokens.len()
        )));
    }
    let n = tokens.len().max(1) as f32;
    let weights: Vec<f32> = maps
        .weights
        .clone()
        .unwrap_or_else(|| vec![1.0 / n; tokens.len()]);
    Ok(AttentionTrace {
        words: tokens
            .iter()
            .zip(words.iter().zip(&weights))
            .map(|(&t, (map, &weight))| WordAttention {
                word: crate::env::vocab::word(t).unwrap_or("?").to_owned(),
                token: t,
                map: *map,
                entropy: entropy(map),
                weight,
            })
            .collect(),
        combined: maps.combined.unwrap_or_else(|| combine(words, &weights)),
    })
}
