//! The network's weights, one named struct per block, taken from the name → tensor map of a
//! checkpoint or of [`super::Params`] (PyTorch's names, [`super::params::param_specs`]) once,
//! when a [`super::Net`] is made: a missing tensor is an error then, and the forward code
//! reads fields instead of looking names up.

use std::collections::BTreeMap;

use candle_core::Tensor;

use super::config::ModelConfig;
use super::error::PolicyError;

/// The matrices an acting net also keeps transposed ([`Weights::new`]): the large ones. The
/// small ones (heads, attention projections) are cheap to repack, and gemm's small-size paths
/// do not give the same bits for both layouts.
pub const TRANSPOSED: [&str; 4] = [
    "lstm.weight_ih_l0",
    "lstm.weight_hh_l0",
    "gru.weight_ih_l0",
    "gru.weight_hh_l0",
];

/// A matrix `W` used as `x · Wᵀ`, with a contiguous `Wᵀ` where the net keeps one
/// ([`TRANSPOSED`], detached weights only).
#[derive(Clone, Debug)]
pub(crate) struct Matrix {
    /// `W`, as stored.
    pub w: Tensor,
    /// `Wᵀ` contiguous, for [`super::kernels::times_transposed`].
    pub wt: Option<Tensor>,
}

/// A linear layer `y = x Wᵀ + b`.
#[derive(Clone, Debug)]
pub(crate) struct Linear {
    /// `W` (out, in).
    pub w: Matrix,
    /// `b` (out).
    pub b: Tensor,
}

/// A convolution over the cells' codes: weight (K, codes, k, k) and bias (K).
#[derive(Clone, Debug)]
pub(crate) struct Conv {
    /// The kernel.
    pub w: Tensor,
    /// The bias.
    pub b: Tensor,
}

/// A recurrent cell (LSTM: gates i, f, g, o; GRU: r, z, n), PyTorch's `*_l0` tensors.
#[derive(Clone, Debug)]
pub(crate) struct Recurrent {
    /// Input-to-hidden `W_ih`.
    pub w_ih: Matrix,
    /// Hidden-to-hidden `W_hh`.
    pub w_hh: Matrix,
    /// `b_ih`.
    pub b_ih: Tensor,
    /// `b_hh`.
    pub b_hh: Tensor,
}

/// The attention's projections (attention variant).
#[derive(Clone, Debug)]
pub(crate) struct Attention {
    /// `W_q` (d_k, E).
    pub q: Matrix,
    /// `W_k` (d_k, K).
    pub k: Tensor,
    /// The search query `q_s` (1, d_k), [`ModelConfig::search_query`] only.
    pub search: Option<Tensor>,
    /// The null key `k₀` (1, d_k), [`ModelConfig::null_key`] only.
    pub null: Option<Tensor>,
}

/// The actor's or the critic's two layers around a tanh.
#[derive(Clone, Debug)]
pub(crate) struct Head {
    /// `z → hidden`.
    pub hidden: Linear,
    /// `hidden → outputs`.
    pub out: Linear,
}

/// Every weight of the network, by block.
#[derive(Clone, Debug)]
pub(crate) struct Weights {
    /// The first layer over the cells' codes (`encoder.conv.*`).
    pub encoder: Conv,
    /// The split keys' own encoder (`encoder.key_conv.*`), [`ModelConfig::key_kernel`] only.
    pub key_encoder: Option<Conv>,
    /// The layout path's encoder (`layout.conv.*`), [`ModelConfig::layout_path`] only.
    pub layout_encoder: Option<Conv>,
    /// Word embeddings (`word_emb.weight`).
    pub word_emb: Tensor,
    /// The attention (`attention.*`), attention variant only.
    pub attention: Option<Attention>,
    /// The LSTM over the visual features.
    pub lstm: Recurrent,
    /// The GRU over the mission's words.
    pub gru: Recurrent,
    /// `actor.0`, `actor.2`.
    pub actor: Head,
    /// `critic.0`, `critic.2`.
    pub critic: Head,
}

impl Weights {
    /// Takes the blocks of `cfg`'s network from `w`. Detached [`TRANSPOSED`] matrices also get
    /// a contiguous copy of their transpose: candle hands `x · W.t()` to gemm with `W`
    /// strided, and gemm then repacks all of `W` on every call, which for the rollout's 16
    /// rows cost more than the product itself (issue #16). A tracked (variable) tensor gets
    /// none, so training's products keep their gradients.
    pub fn new(cfg: &ModelConfig, mut w: BTreeMap<String, Tensor>) -> Result<Self, PolicyError> {
        let w = &mut w;
        let attention = if cfg.has_attention() {
            Some(Attention {
                q: matrix(w, "attention.q.weight")?,
                k: take(w, "attention.k.weight")?,
                search: if cfg.search_query {
                    Some(take(w, "attention.search.weight")?)
                } else {
                    None
                },
                null: if cfg.null_key {
                    Some(take(w, super::params::NULL_KEY)?)
                } else {
                    None
                },
            })
        } else {
            None
        };
        Ok(Self {
            encoder: conv(w, "encoder.conv")?,
            key_encoder: match cfg.key_kernel {
                Some(_) if cfg.has_attention() => Some(conv(w, "encoder.key_conv")?),
                _ => None,
            },
            layout_encoder: if cfg.layout_path {
                Some(conv(w, LAYOUT_CONV)?)
            } else {
                None
            },
            word_emb: take(w, "word_emb.weight")?,
            attention,
            lstm: recurrent(w, "lstm")?,
            gru: recurrent(w, "gru")?,
            actor: Head {
                hidden: linear(w, "actor.0")?,
                out: linear(w, "actor.2")?,
            },
            critic: Head {
                hidden: linear(w, "critic.0")?,
                out: linear(w, "critic.2")?,
            },
        })
    }
}

/// The layout path's encoder's tensors' prefix ([`ModelConfig::layout_path`]).
pub(crate) const LAYOUT_CONV: &str = "layout.conv";

type Named = BTreeMap<String, Tensor>;

fn take(w: &mut Named, name: &str) -> Result<Tensor, PolicyError> {
    w.remove(name)
        .ok_or_else(|| PolicyError::Input(format!("missing parameter {name}")))
}

fn matrix(w: &mut Named, name: &str) -> Result<Matrix, PolicyError> {
    let m = take(w, name)?;
    let wt = (TRANSPOSED.contains(&name) && m.rank() == 2 && !m.is_variable())
        // A transpose that cannot be made leaves the strided product, also right.
        .then(|| m.t().ok()?.contiguous().ok())
        .flatten();
    Ok(Matrix { w: m, wt })
}

fn linear(w: &mut Named, prefix: &str) -> Result<Linear, PolicyError> {
    Ok(Linear {
        w: matrix(w, &format!("{prefix}.weight"))?,
        b: take(w, &format!("{prefix}.bias"))?,
    })
}

fn recurrent(w: &mut Named, rnn: &str) -> Result<Recurrent, PolicyError> {
    Ok(Recurrent {
        w_ih: matrix(w, &format!("{rnn}.weight_ih_l0"))?,
        w_hh: matrix(w, &format!("{rnn}.weight_hh_l0"))?,
        b_ih: take(w, &format!("{rnn}.bias_ih_l0"))?,
        b_hh: take(w, &format!("{rnn}.bias_hh_l0"))?,
    })
}

fn conv(w: &mut Named, prefix: &str) -> Result<Conv, PolicyError> {
    Ok(Conv {
        w: take(w, &format!("{prefix}.weight"))?,
        b: take(w, &format!("{prefix}.bias"))?,
    })
}
