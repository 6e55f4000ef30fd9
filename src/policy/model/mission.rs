//! The mission side of the network: word embeddings, the GRU's text code and the word
//! queries, per distinct mission and gathered per frame ([`MissionInputs`]).

use candle_core::{DType, Device, Tensor};

use super::Net;
use crate::policy::config::AttendWords;
use crate::policy::error::PolicyError;
use crate::policy::kernels::act;
use crate::policy::obs::TokenBatch;

impl Net {
    /// Word embeddings `g̃` of the distinct missions: (U, L, E).
    pub fn embed(&self, tb: &TokenBatch) -> Result<Tensor, PolicyError> {
        // A word past the embedding's rows was never trained: refuse it by name.
        if let Some(&t) = tb
            .distinct
            .iter()
            .flatten()
            .find(|&&t| t as usize >= self.cfg.vocab_size)
        {
            return Err(PolicyError::Input(format!(
                "the mission word {:?} is not one this model was trained on: it knows the paper's \
                 {} words (a model trained on the paper's level); use `--checkpoint \
                 bundled:babyai`, which reads every BabyAI level, or train one on a BabyAI level \
                 (`train --level ID`)",
                crate::env::vocab::word(t).unwrap_or("?"),
                self.cfg.vocab_size - 1
            )));
        }
        let (u, l) = tb.tokens.dims2()?;
        let emb = &self.weights.word_emb;
        Ok(emb
            .index_select(&tb.tokens.flatten_all()?, 0)?
            .reshape((u, l, self.cfg.word_dim))?)
    }

    /// The GRU over each distinct mission's real words; its last state: (U, H_gru). One fused
    /// op over all the words ([`crate::policy::kernels::gru`]), the same bits as
    /// [`Self::encode_text_reference`].
    pub fn encode_text(&self, tb: &TokenBatch, emb: &Tensor) -> Result<Tensor, PolicyError> {
        let gru = &self.weights.gru;
        Ok(crate::policy::kernels::gru::gru_sequence(
            &self.gru_inputs(tb, emb)?,
            &gru.w_hh.w,
            gru.w_hh.wt.as_ref(),
            &gru.b_hh,
            &tb.mask,
        )?)
    }

    /// The words' input projections `x W_ihᵀ + b_ih`: (U, L, 3·H_gru).
    fn gru_inputs(&self, tb: &TokenBatch, emb: &Tensor) -> Result<Tensor, PolicyError> {
        let (u, l) = tb.tokens.dims2()?;
        let gru = &self.weights.gru;
        Ok(crate::policy::kernels::bias::add_bias(
            &Self::times_t(&emb.reshape((u * l, self.cfg.word_dim))?, &gru.w_ih)?,
            &gru.b_ih,
        )?
        .reshape((u, l, 3 * self.cfg.gru_hidden))?)
    }

    /// [`Self::encode_text`] word by word in candle ops: the reference the fused op is
    /// checked against (`tests/it/policy/fused.rs`).
    pub fn encode_text_reference(
        &self,
        tb: &TokenBatch,
        emb: &Tensor,
    ) -> Result<Tensor, PolicyError> {
        let (u, l) = tb.tokens.dims2()?;
        let hg = self.cfg.gru_hidden;
        let gru = &self.weights.gru;
        let b_hh = &gru.b_hh;
        let gx_all = self.gru_inputs(tb, emb)?;
        let mut h = Tensor::zeros((u, hg), DType::F32, &Device::Cpu)?;
        for t in 0..l {
            let gx = gx_all.narrow(1, t, 1)?.squeeze(1)?;
            let gh = Self::times_t(&h, &gru.w_hh)?.broadcast_add(b_hh)?;
            let rz = act::sigmoid(&(gx.narrow(1, 0, 2 * hg)? + gh.narrow(1, 0, 2 * hg)?)?)?;
            let r = rz.narrow(1, 0, hg)?;
            let z = rz.narrow(1, hg, hg)?;
            let n = act::tanh(&(gx.narrow(1, 2 * hg, hg)? + (r * gh.narrow(1, 2 * hg, hg)?)?)?)?;
            let h_new = ((&n + (&z * (&h - &n)?)?)?).clone();
            // Padding steps keep the state: h = h_new·valid + h·(1 − valid).
            let valid = tb.mask.narrow(1, t, 1)?;
            h = (&h + (h_new - &h)?.broadcast_mul(&valid)?)?;
        }
        Ok(h)
    }

    /// Word queries `Q = g̃ W_q` of the distinct missions: (U, L, d_k).
    pub fn queries(&self, emb: &Tensor) -> Result<Tensor, PolicyError> {
        let (u, l, e) = emb.dims3()?;
        Ok(
            Self::times_t(&emb.reshape((u * l, e))?, &self.attention_weights()?.q)?.reshape((
                u,
                l,
                self.cfg.key_dim,
            ))?,
        )
    }

    /// The mission inputs of the training path: text codes per frame and, for attention, the
    /// keyed queries `Q̂` ([`crate::policy::attention::keyed_queries`], computed per distinct mission;
    /// with the null key one more column, [`crate::policy::attention::null_logits`])
    /// and the mask, gathered per frame.
    pub fn mission_inputs_keyed(&self, tb: &TokenBatch) -> Result<MissionInputs, PolicyError> {
        let emb = self.embed(tb)?;
        let text = self.encode_text(tb, &emb)?.index_select(&tb.index, 0)?;
        let queries = if self.cfg.has_attention() {
            let att = self.attention_weights()?;
            let q = self.queries(&emb)?;
            let qk = crate::policy::attention::keyed_queries(&q, &att.k)?;
            // With the null key each row also carries its null logit, as the fused op reads it.
            let qk = match &att.null {
                Some(k0) => {
                    Tensor::cat(&[&qk, &crate::policy::attention::null_logits(&q, k0)?], 2)?
                }
                None => qk,
            }
            .index_select(&tb.index, 0)?;
            let mask = self.attention_mask(tb)?.index_select(&tb.index, 0)?;
            Some((qk, mask))
        } else {
            None
        };
        Ok(MissionInputs { text, queries })
    }

    /// The attention's word mask (U, L) of the distinct missions: the padding mask, with the
    /// words [`ModelConfig::attend_words`] leaves out set to 0 as well.
    fn attention_mask(&self, tb: &TokenBatch) -> Result<Tensor, PolicyError> {
        if self.cfg.attend_words == AttendWords::All {
            return Ok(tb.mask.clone());
        }
        let (u, l) = tb.mask.dims2()?;
        let mut mask = vec![0f32; u * l];
        for (row, d) in mask.chunks_mut(l).zip(&tb.distinct) {
            row[..d.len()].copy_from_slice(&self.cfg.attend_words.mask(d));
        }
        Ok(Tensor::from_vec(mask, (u, l), tb.mask.device())?)
    }

    /// Everything that depends only on the missions: text codes and queries per frame.
    pub fn mission_inputs(&self, tb: &TokenBatch) -> Result<MissionInputs, PolicyError> {
        let emb = self.embed(tb)?;
        let text = self.encode_text(tb, &emb)?.index_select(&tb.index, 0)?;
        let queries = if self.cfg.has_attention() {
            let q = self.queries(&emb)?.index_select(&tb.index, 0)?;
            let mask = self.attention_mask(tb)?.index_select(&tb.index, 0)?;
            Some((q, mask))
        } else {
            None
        };
        Ok(MissionInputs { text, queries })
    }
}

/// Per-frame mission inputs: the GRU code (B, H_gru) and, for attention, queries and mask.
#[derive(Clone, Debug)]
pub struct MissionInputs {
    /// (B, H_gru).
    pub text: Tensor,
    /// (B, L, d_k) queries and (B, L) word mask.
    pub queries: Option<(Tensor, Tensor)>,
}

impl MissionInputs {
    /// The rows `rows` (u32 indices), e.g. the environments still running.
    pub fn select(&self, rows: &Tensor) -> Result<Self, PolicyError> {
        Ok(Self {
            text: self.text.index_select(rows, 0)?,
            queries: match &self.queries {
                Some((q, m)) => Some((q.index_select(rows, 0)?, m.index_select(rows, 0)?)),
                None => None,
            },
        })
    }
}
