//! Attention traces: what each word looked at, extracted once from a forward pass.
//!
//! Maps are 7 rows of 7, agent-up: row = view row `vy` (row 0 farthest ahead, row 6 the
//! agent's row), column = `vx` (the agent at column 3).

use serde::{Deserialize, Serialize};

use super::attention::AttentionOut;
use super::error::PolicyError;
use crate::env::view::VIEW_SIZE;
use crate::env::vocab;

/// A 7×7 map, `map[vy][vx]`.
pub type ViewMap = [[f32; VIEW_SIZE]; VIEW_SIZE];

/// Converts 49 values in agent-up order (`j = vy·7 + vx`) to a map.
pub fn to_map(v: &[f32]) -> ViewMap {
    let mut m = [[0.0; VIEW_SIZE]; VIEW_SIZE];
    for (j, x) in v.iter().take(VIEW_SIZE * VIEW_SIZE).enumerate() {
        m[j / VIEW_SIZE][j % VIEW_SIZE] = *x;
    }
    m
}

/// One word's attention: its token, map `A_i`, entropy `H_i` (nats) and weight `w_i`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WordAttention {
    /// The word.
    pub word: String,
    /// Its token id.
    pub token: u32,
    /// `A_i` as 7 rows of 7.
    pub map: ViewMap,
    /// `H_i` in nats.
    pub entropy: f32,
    /// `w_i`.
    pub weight: f32,
}

/// The attention trace of one frame: every real word, plus the combined map `M`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AttentionTrace {
    /// One entry per mission word, in mission order.
    pub words: Vec<WordAttention>,
    /// `M = Σ w_i A_i` as 7 rows of 7.
    pub combined: ViewMap,
}

/// Extracts the traces of every batch row; `tokens[b]` are row b's real tokens.
pub fn extract(att: &AttentionOut, tokens: &[&[u32]]) -> Result<Vec<AttentionTrace>, PolicyError> {
    let a = att.a.to_vec3::<f32>()?;
    let h = att.h.to_vec2::<f32>()?;
    let w = att.w.to_vec2::<f32>()?;
    let m = att.m.to_vec2::<f32>()?;
    let mut out = Vec::with_capacity(tokens.len());
    for (b, toks) in tokens.iter().enumerate() {
        let words = toks
            .iter()
            .enumerate()
            .map(|(i, &t)| WordAttention {
                word: vocab::word(t).unwrap_or("?").to_owned(),
                token: t,
                map: to_map(&a[b][i]),
                entropy: h[b][i],
                weight: w[b][i],
            })
            .collect();
        out.push(AttentionTrace {
            words,
            combined: to_map(&m[b]),
        });
    }
    Ok(out)
}
