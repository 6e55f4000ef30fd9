//! The policy network (paper §3.3) and its no-attention baseline.
//!
//! ```text
//! O (7×7 one-hot codes) ─conv3×3→ Õ (49×K) ─┬─ attention(Q from words, Kc from Õ) → A, H, w, M
//!                                            └─ F = 49·M⊙Õ (baseline: F = Õ) → LSTM ─┐
//! mission words → embeddings g̃ → GRU ──────────────────────────────────────────────────┴→ actor (7), critic (1)
//! ```
//! The LSTM and GRU follow PyTorch's equations and gate orders (LSTM i, f, g, o; GRU r, z, n).

mod lstm;
mod mission;

use std::collections::BTreeMap;

use candle_core::{D, DType, Device, Tensor};

use super::attention::{AttentionOut, Intervention, attend_with};
use super::config::{ColourCodes, ModelConfig};
use super::error::PolicyError;
use super::kernels::{act, times_transposed};
use super::obs::{CellCodes, N_CELLS, TokenBatch, patch_len};
use crate::env::world::Action;

pub use super::weights::TRANSPOSED;
use super::weights::{Linear, Matrix, Weights};
pub use mission::MissionInputs;

/// The network's weights plus its config; cheap to clone (tensors share storage).
#[derive(Clone, Debug)]
pub struct Net {
    /// Sizes and variant.
    pub cfg: ModelConfig,
    /// The weights by block.
    weights: Weights,
}

/// What [`Net::sequence_with_maps`] computes for a chunk of frames.
#[derive(Clone, Debug)]
pub struct SequenceOut {
    /// Action logits, one row per frame.
    pub logits: Tensor,
    /// Values, one per frame.
    pub values: Tensor,
    /// The memory after each chunk step.
    pub mems: Vec<Memory>,
    /// The word maps `A` (B, m, 49) and `M` (B, 49), when asked for.
    pub maps: Option<(Tensor, Tensor)>,
}

/// Recurrent memory of B environments: LSTM `h` and `c`, each (B, H).
#[derive(Clone, Debug)]
pub struct Memory {
    /// Hidden state.
    pub h: Tensor,
    /// Cell state.
    pub c: Tensor,
}

impl Memory {
    /// Zero memory for `batch` environments.
    pub fn zeros(batch: usize, hidden: usize) -> Result<Self, PolicyError> {
        let z = Tensor::zeros((batch, hidden), DType::F32, &Device::Cpu)?;
        Ok(Self { h: z.clone(), c: z })
    }

    /// Memory with rows where `keep` is 0 reset to zero (episode starts).
    pub fn masked(&self, keep: &Tensor) -> Result<Self, PolicyError> {
        let k = keep.unsqueeze(1)?;
        Ok(Self {
            h: self.h.broadcast_mul(&k)?,
            c: self.c.broadcast_mul(&k)?,
        })
    }
}

/// Output of the visual path for a batch of frames.
#[derive(Clone, Debug)]
pub struct Visual {
    /// (B, 49·K) LSTM input; (B, 2·49·K) with the search query; the layout path's 49·K
    /// columns last ([`ModelConfig::lstm_input_size`]) once [`Net::step_with`] has added them.
    pub x: Tensor,
    /// Attention tensors (attention variant only).
    pub attention: Option<AttentionOut>,
    /// (B, 49) the search query's map `S` ([`ModelConfig::search_query`] only).
    pub search: Option<Tensor>,
}

impl Net {
    /// Wraps named weights (tracked for training, detached for acting), taking each block's
    /// tensors by name once ([`Weights::new`]; a missing one is an error here). A net of
    /// detached weights keeps contiguous transposes of its large matrices, so it must not
    /// outlive an update of those weights (the trainer makes a new one for every rollout).
    pub fn new(cfg: ModelConfig, w: BTreeMap<String, Tensor>) -> Result<Self, PolicyError> {
        Ok(Self {
            cfg,
            weights: Weights::new(&cfg, w)?,
        })
    }

    /// The attention's weights (attention variant).
    fn attention_weights(&self) -> Result<&super::weights::Attention, PolicyError> {
        self.weights
            .attention
            .as_ref()
            .ok_or_else(|| PolicyError::Input("the baseline has no attention weights".into()))
    }

    /// `x · Wᵀ` for a 2-D `x`, through [`times_transposed`] with the net's contiguous
    /// transpose where it keeps one.
    fn times_t(x: &Tensor, m: &Matrix) -> Result<Tensor, PolicyError> {
        Ok(times_transposed(x, &m.w, m.wt.as_ref())?)
    }

    fn linear(x: &Tensor, l: &Linear) -> Result<Tensor, PolicyError> {
        Ok(super::kernels::bias::add_bias(
            &Self::times_t(x, &l.w)?,
            &l.b,
        )?)
    }

    /// `Õ = ReLU(Conv(O))` (3×3 or 1×1, `conv_kernel`) for the B frames of `codes`:
    /// (B, 49, K), through the sparse op of [`super::kernels::conv`]. The codes are read as the
    /// model's `colour_codes` says ([`CellCodes::encoded`]).
    pub fn cells(&self, codes: &CellCodes) -> Result<Tensor, PolicyError> {
        let (k, ks) = (self.cfg.conv_channels, self.cfg.conv_kernel);
        let w = self.weights.encoder.w.reshape((k, patch_len(ks)))?;
        let b = &self.weights.encoder.b;
        Ok(super::kernels::conv::conv_codes(
            &self.read_codes(codes),
            ks,
            &w,
            b,
        )?)
    }

    /// The split keys' features `Õ_key = ReLU(Conv_key(O))` (B, 49, K) of a model with
    /// [`ModelConfig::key_kernel`] set, through the same sparse op as [`Self::cells`]; `None`
    /// for the paper's model, whose keys come from `Õ` itself.
    pub fn key_cells(&self, codes: &CellCodes) -> Result<Option<Tensor>, PolicyError> {
        let Some(ks) = self.cfg.key_kernel.filter(|_| self.cfg.has_attention()) else {
            return Ok(None);
        };
        let k = self.cfg.conv_channels;
        let conv = self.weights.key_encoder.as_ref().ok_or_else(|| {
            PolicyError::Input("missing parameter encoder.key_conv.weight".into())
        })?;
        let w = conv.w.reshape((k, patch_len(ks)))?;
        let b = &conv.b;
        Ok(Some(super::kernels::conv::conv_codes(
            &self.read_codes(codes),
            ks,
            &w,
            b,
        )?))
    }

    /// `x` (B, filter features) with the layout path's features `L = ReLU(Conv_layout(O'))`
    /// (B, 49·K) after it, where `O'` is the layout of the codes ([`CellCodes::layout`]) and
    /// the model has a [`ModelConfig::layout_path`]; `x` itself otherwise.
    fn with_layout(&self, x: Tensor, codes: &CellCodes) -> Result<Tensor, PolicyError> {
        let Some(conv) = self.weights.layout_encoder.as_ref() else {
            return Ok(x);
        };
        let (k, ks) = (self.cfg.conv_channels, self.cfg.conv_kernel);
        let w = conv.w.reshape((k, patch_len(ks)))?;
        let l =
            super::kernels::conv::conv_codes(&self.read_codes(codes).layout(), ks, &w, &conv.b)?;
        let b = l.dim(0)?;
        Ok(Tensor::cat(&[x, l.reshape((b, N_CELLS * k))?], 1)?)
    }

    /// The codes as the model's `colour_codes` reads them ([`CellCodes::encoded`]).
    fn read_codes<'a>(&self, codes: &'a CellCodes) -> std::borrow::Cow<'a, CellCodes> {
        match self.cfg.colour_codes {
            ColourCodes::All => std::borrow::Cow::Borrowed(codes),
            c => std::borrow::Cow::Owned(codes.encoded(c)),
        }
    }

    /// [`Self::cells`] as a dense GEMM over the im2col patches (B·49, patch) of
    /// [`super::obs::patches`] (of the codes as the model reads them) with candle's autograd:
    /// the reference the sparse op is tested against.
    pub fn cells_reference(&self, patches: &Tensor) -> Result<Tensor, PolicyError> {
        let k = self.cfg.conv_channels;
        let w = self
            .weights
            .encoder
            .w
            .reshape((k, patch_len(self.cfg.conv_kernel)))?;
        let b = &self.weights.encoder.b;
        let rows = patches.dim(0)?;
        let o = patches.matmul(&w.t()?)?.broadcast_add(b)?.relu()?;
        Ok(o.reshape((rows / N_CELLS, N_CELLS, k))?)
    }

    /// The visual path for B frames: `Õ`, then (attention variant) `Kc`, A, H, w, M and `F`.
    /// `q` is (B, L, d_k) and `mask` (B, L), both gathered per frame; `o_key` the split keys'
    /// features ([`Self::key_cells`]), `None` to take the keys from `o`.
    pub fn visual(
        &self,
        o: &Tensor,
        o_key: Option<&Tensor>,
        q: Option<(&Tensor, &Tensor)>,
    ) -> Result<Visual, PolicyError> {
        self.visual_with(o, o_key, q, None)
    }

    /// [`Self::visual`] with an [`Intervention`] on the attention (ignored by the baseline).
    pub fn visual_with(
        &self,
        o: &Tensor,
        o_key: Option<&Tensor>,
        q: Option<(&Tensor, &Tensor)>,
        intervention: Option<&Intervention>,
    ) -> Result<Visual, PolicyError> {
        let (b, n, k) = o.dims3()?;
        match q {
            Some((q, mask)) if self.cfg.has_attention() => {
                let att = self.attention_weights()?;
                let key_in = match o_key {
                    Some(ok) if self.cfg.key_context => Tensor::cat(&[ok, o], 2)?,
                    Some(ok) => ok.clone(),
                    None => o.clone(),
                };
                let width = key_in.dim(2)?;
                let kc = times_transposed(&key_in.reshape((b * n, width))?, &att.k, None)?
                    .reshape((b, n, self.cfg.key_dim))?;
                let out = attend_with(
                    q,
                    &kc,
                    mask,
                    o,
                    self.cfg.filter_scale,
                    self.cfg.word_temperature.0,
                    att.null.as_ref(),
                    intervention,
                )?;
                let f = out.f.reshape((b, n * k))?;
                let (x, search) = if self.cfg.search_query {
                    let qs = search_query(att)?
                        .unsqueeze(0)?
                        .broadcast_as((b, 1, self.cfg.key_dim))?
                        .contiguous()?;
                    let s_map = super::attention::attention_maps(&qs, &kc)?.squeeze(1)?;
                    let fs = super::attention::filter_features(o, &s_map, self.cfg.filter_scale)?;
                    (Tensor::cat(&[f, fs.reshape((b, n * k))?], 1)?, Some(s_map))
                } else {
                    (f, None)
                };
                Ok(Visual {
                    x: self.normalised(x, o)?,
                    attention: Some(out),
                    search,
                })
            }
            _ => Ok(Visual {
                x: o.reshape((b, n * k))?,
                attention: None,
                search: None,
            }),
        }
    }

    /// The visual path for training: `F` only, through the fused attention op
    /// ([`super::kernels::attention::attention_filter`], same maths as [`Self::visual`] with its
    /// own backward). `keyed` is the per-frame `Q̂ = Q W_k / √d_k` (B, L, K) and mask (B, L);
    /// the baseline's path is unchanged.
    ///
    /// With split keys (`o_key`) the same op runs on the channels `[Õ_key | Õ]` with `Q̂`
    /// padded by zeros on `Õ`'s channels — the scores are then `Q̂ Õ_keyᵀ` — and only `Õ`'s
    /// channels of its output are kept, so `Õ_key` gets its gradient through the maps alone.
    /// With [`ModelConfig::key_context`] `Q̂` is 2K wide and is not padded: the scores read
    /// both halves.
    pub fn visual_features(
        &self,
        o: &Tensor,
        o_key: Option<&Tensor>,
        keyed: Option<(&Tensor, &Tensor)>,
    ) -> Result<Tensor, PolicyError> {
        let x = self.filter_features(o, o_key, keyed)?;
        match keyed {
            Some(_) if self.cfg.has_attention() => self.normalised(x, o),
            _ => Ok(x),
        }
    }

    /// The filter's output per frame, (B, [`ModelConfig::filter_input_size`]), each 49·K copy
    /// (`F`, and `F_S` with the search query) rescaled to `Õ`'s norm, `F · ‖Õ‖ / ‖F‖`, with
    /// [`ModelConfig::filter_norm`]; `x` itself otherwise. `o` is `Õ`, (B, 49, K).
    fn normalised(&self, x: Tensor, o: &Tensor) -> Result<Tensor, PolicyError> {
        // Keeps an all-zero view (every feature dead after the ReLU) at zero, not NaN.
        const EPS: f64 = 1e-12;
        if !self.cfg.filter_norm {
            return Ok(x);
        }
        let b = x.dim(0)?;
        let norm = |t: &Tensor| -> candle_core::Result<Tensor> {
            (t.sqr()?.sum_keepdim(1)? + EPS)?.sqrt()
        };
        let o_norm = norm(&o.reshape((b, ()))?)?;
        let width = N_CELLS * self.cfg.conv_channels;
        let copies = (0..x.dim(1)? / width)
            .map(|i| {
                let f = x.narrow(1, i * width, width)?;
                f.broadcast_mul(&(&o_norm / norm(&f)?)?)
            })
            .collect::<candle_core::Result<Vec<_>>>()?;
        Ok(Tensor::cat(&copies, 1)?)
    }

    /// [`Self::visual_features`] before [`Self::normalised`].
    fn filter_features(
        &self,
        o: &Tensor,
        o_key: Option<&Tensor>,
        keyed: Option<(&Tensor, &Tensor)>,
    ) -> Result<Tensor, PolicyError> {
        let (b, n, k) = o.dims3()?;
        let (scale, t) = (self.cfg.filter_scale, self.cfg.word_temperature.0);
        match (keyed, o_key) {
            (Some((qk, mask)), None) if self.cfg.has_attention() && self.cfg.null_key => {
                let f = super::kernels::attention::attention_filter_null(qk, mask, o, scale, t)?;
                Ok(f.reshape((b, n * k))?)
            }
            (Some((qk, mask)), None) if self.cfg.has_attention() => {
                let f = super::kernels::attention::attention_filter(qk, mask, o, scale, t)?;
                let f = f.reshape((b, n * k))?;
                if !self.cfg.search_query {
                    return Ok(f);
                }
                // The search map through the same fused op: one "word" that always counts,
                // so its weight is 1 and its filter is `s · S ⊙ Õ` (T plays no part).
                let att = self.attention_weights()?;
                let qs =
                    super::attention::keyed_queries(&search_query(att)?.unsqueeze(0)?, &att.k)?
                        .broadcast_as((b, 1, k))?
                        .contiguous()?;
                let ones = Tensor::ones((b, 1), DType::F32, o.device())?;
                let fs = super::kernels::attention::attention_filter(&qs, &ones, o, scale, t)?;
                Ok(Tensor::cat(&[f, fs.reshape((b, n * k))?], 1)?)
            }
            (Some((qk, mask)), Some(ok)) if self.cfg.has_attention() => {
                let both = Tensor::cat(&[ok, o], 2)?;
                let f = if self.cfg.key_context {
                    // Q̂ is already 2K wide: the scores read both halves of the channels.
                    super::kernels::attention::attention_filter(qk, mask, &both, scale, t)?
                } else if self.cfg.null_key {
                    // The null logit stays the last column, after the zeros on `Õ`'s channels.
                    let kq = qk.narrow(2, 0, k)?;
                    let padded = Tensor::cat(&[&kq, &kq.zeros_like()?, &qk.narrow(2, k, 1)?], 2)?;
                    super::kernels::attention::attention_filter_null(
                        &padded, mask, &both, scale, t,
                    )?
                } else {
                    let padded = Tensor::cat(&[qk, &qk.zeros_like()?], 2)?;
                    super::kernels::attention::attention_filter(&padded, mask, &both, scale, t)?
                };
                Ok(f.narrow(2, k, k)?.reshape((b, n * k))?)
            }
            _ => Ok(o.reshape((b, n * k))?),
        }
    }

    /// Actor logits (B, 7) and critic values (B,) from the LSTM output and the text code.
    pub fn heads(&self, h: &Tensor, text: &Tensor) -> Result<(Tensor, Tensor), PolicyError> {
        let z = Tensor::cat(&[h, text], 1)?;
        let (actor, critic) = (&self.weights.actor, &self.weights.critic);
        let a = Self::linear(&act::tanh(&Self::linear(&z, &actor.hidden)?)?, &actor.out)?;
        let v = Self::linear(&act::tanh(&Self::linear(&z, &critic.hidden)?)?, &critic.out)?;
        Ok((a, v.squeeze(1)?))
    }

    /// One step for B frames: returns logits, values, the new memory and the visual outputs.
    pub fn step(
        &self,
        codes: &CellCodes,
        mission: &MissionInputs,
        mem: &Memory,
    ) -> Result<(Tensor, Tensor, Memory, Visual), PolicyError> {
        self.step_with(codes, mission, mem, None)
    }

    /// [`Self::step`] with an [`Intervention`] on the attention.
    pub fn step_with(
        &self,
        codes: &CellCodes,
        mission: &MissionInputs,
        mem: &Memory,
        intervention: Option<&Intervention>,
    ) -> Result<(Tensor, Tensor, Memory, Visual), PolicyError> {
        let o = self.cells(codes)?;
        let o_key = self.key_cells(codes)?;
        let vis = self.visual_with(
            &o,
            o_key.as_ref(),
            mission.queries.as_ref().map(|(q, m)| (q, m)),
            intervention,
        )?;
        let vis = Visual {
            x: self.with_layout(vis.x, codes)?,
            ..vis
        };
        let gx = self.lstm_input(&vis.x)?;
        let mem = self.lstm_cell(&gx, mem)?;
        let (logits, values) = self.heads(&mem.h, &mission.text)?;
        Ok((logits, values, mem, vis))
    }

    /// One step for B frames through the training path's fused ops (sparse conv, keyed
    /// queries, fused attention): logits, values and the new memory, no attention tensors.
    /// The trainer's rollouts use it; everything that shows or replays an episode uses
    /// [`Self::step_with`], whose rounding it does not share.
    /// `mission` comes from [`Self::mission_inputs_keyed`] (whole, or its rows `select`ed).
    pub fn step_untraced(
        &self,
        codes: &CellCodes,
        mission: &MissionInputs,
        mem: &Memory,
    ) -> Result<(Tensor, Tensor, Memory), PolicyError> {
        let o = self.cells(codes)?;
        let o_key = self.key_cells(codes)?;
        let x = self.visual_features(
            &o,
            o_key.as_ref(),
            mission.queries.as_ref().map(|(q, m)| (q, m)),
        )?;
        let x = self.with_layout(x, codes)?;
        // A chunk of one step through the training path's LSTM op (`mem` is already reset).
        let keep = Tensor::ones((1, mem.h.dim(0)?), DType::F32, &Device::Cpu)?;
        let (h, mut mems) = self.lstm_chunk(&x, mem, &keep)?;
        let mem = mems
            .pop()
            .ok_or_else(|| PolicyError::Input("empty chunk".into()))?;
        let (logits, values) = self.heads(&h, &mission.text)?;
        Ok((logits, values, mem))
    }

    /// A recurrent sequence for training: `codes` hold T·n frames in t-major order
    /// (row = t·n + j), `tb` their missions, `keep` is (T, n) with 0 where an episode starts
    /// at step t. Returns logits (T·n, 7), values (T·n,) and the memory after every step.
    pub fn sequence(
        &self,
        codes: &CellCodes,
        tb: &TokenBatch,
        mem0: &Memory,
        keep: &Tensor,
    ) -> Result<(Tensor, Tensor, Vec<Memory>), PolicyError> {
        let out = self.sequence_with_maps(codes, tb, mem0, keep, false)?;
        Ok((out.logits, out.values, out.mems))
    }

    /// [`Self::sequence`], with every frame's word maps and `M` (with gradient) when `maps`
    /// is set and the model attends: what `train --ground-loss` supervises.
    pub fn sequence_with_maps(
        &self,
        codes: &CellCodes,
        tb: &TokenBatch,
        mem0: &Memory,
        keep: &Tensor,
        maps: bool,
    ) -> Result<SequenceOut, PolicyError> {
        let mission = self.mission_inputs_keyed(tb)?;
        let o = self.cells(codes)?;
        let o_key = self.key_cells(codes)?;
        let queries = mission.queries.as_ref().map(|(q, m)| (q, m));
        let x = self.with_layout(self.visual_features(&o, o_key.as_ref(), queries)?, codes)?;
        let maps = match queries {
            Some((qk, mask)) if maps && self.cfg.has_attention() => {
                Some(self.composite_maps(&o, o_key.as_ref(), qk, mask)?)
            }
            _ => None,
        };
        let (h, mems) = self.lstm_chunk(&x, mem0, keep)?;
        let (logits, values) = self.heads(&h, &mission.text)?;
        Ok(SequenceOut {
            logits,
            values,
            mems,
            maps,
        })
    }

    /// The word maps `A` (B, m, 49) and `M` (B, 49) the fused op of [`Self::visual_features`]
    /// computes inside, through the composite ops of [`super::attention`] so that they carry a
    /// gradient: the scores are `Q̂ Õᵀ` (or `Q̂ Õ_keyᵀ`, `Q̂ [Õ_key | Õ]ᵀ` with split keys and
    /// key context), with the null key's column where the model has one.
    fn composite_maps(
        &self,
        o: &Tensor,
        o_key: Option<&Tensor>,
        qk: &Tensor,
        mask: &Tensor,
    ) -> Result<(Tensor, Tensor), PolicyError> {
        let keys = match o_key {
            None => o.clone(),
            Some(ok) if self.cfg.key_context => Tensor::cat(&[ok, o], 2)?,
            Some(ok) => ok.clone(),
        };
        let width = keys.dim(2)?;
        let s = qk
            .narrow(2, 0, width)?
            .contiguous()?
            .matmul(&keys.transpose(1, 2)?.contiguous()?)?;
        let s0 = if self.cfg.null_key {
            Some(qk.narrow(2, width, 1)?)
        } else {
            None
        };
        let a = super::attention::maps_from_scores(&s, s0.as_ref())?;
        let h = super::attention::entropies(&a)?;
        let w = super::attention::word_weights(&h, mask, self.cfg.word_temperature.0)?;
        let m = super::attention::combined_map(&w, &a)?;
        Ok((a, m))
    }

    /// Number of actions the actor scores.
    pub fn n_actions(&self) -> usize {
        Action::COUNT
    }
}

/// Softmax probabilities of logits on the host, row by row ([`super::acting::softmax`]):
/// candle-nn's `softmax_last_dim` to the bit, without its rayon dispatch — which, called from
/// the training threads, handed every rollout step's rows to rayon's one worker and waited.
pub fn probs_host(logits: &Tensor) -> Result<Vec<Vec<f32>>, PolicyError> {
    Ok(logits
        .to_vec2::<f32>()?
        .iter()
        .map(|row| super::acting::softmax(row))
        .collect())
}

/// Log-probabilities (B, A) with gradient.
pub fn log_probs(logits: &Tensor) -> Result<Tensor, PolicyError> {
    Ok(candle_nn::ops::log_softmax(logits, D::Minus1)?)
}

/// The search query `q_s` of a model with [`ModelConfig::search_query`].
fn search_query(att: &super::weights::Attention) -> Result<&Tensor, PolicyError> {
    att.search
        .as_ref()
        .ok_or_else(|| PolicyError::Input("missing parameter attention.search.weight".into()))
}
