//! Saving and restoring a trainer's run state and Adam moments, for an exact `--resume`.

use std::collections::BTreeMap;

use candle_core::{Device, Tensor};

use super::{MAX_STATE_TOKENS, RunState, Trainer};
use crate::env::vocab;
use crate::policy::error::PolicyError;

impl Trainer {
    /// Serialises the run state (RNG streams, environments, counters) as JSON.
    pub fn state_json(&self) -> Result<String, PolicyError> {
        let mut state = self.state.clone();
        state.missions = self.missions.distinct().to_vec();
        serde_json::to_string(&state)
            .map_err(|e| PolicyError::Input(format!("serialising run state: {e}")))
    }

    /// Restores a run state written by [`Trainer::state_json`], checking every field a later
    /// update relies on; errors name the field (`envs[3].world.agent_pos`, ...).
    pub fn restore_state(&mut self, json: &str) -> Result<(), PolicyError> {
        let mut st: RunState = serde_json::from_str(json)
            .map_err(|e| PolicyError::Input(format!("reading run state: {e}")))?;
        let bad = |field: String, reason: String| PolicyError::Input(format!("{field}: {reason}"));
        if st.envs.len() != self.ppo.procs {
            return Err(bad(
                "envs".into(),
                format!(
                    "{} environments, the run has --procs {}",
                    st.envs.len(),
                    self.ppo.procs
                ),
            ));
        }
        let valid_tokens = |t: &[u32]| {
            !t.is_empty()
                && t.len() <= MAX_STATE_TOKENS
                && t.iter()
                    .all(|&t| t != 0 && (t as usize) < vocab::VOCABULARY.len())
        };
        let mut seen = std::collections::HashSet::new();
        for (k, m) in st.missions.iter().enumerate() {
            if !valid_tokens(m) {
                return Err(bad(
                    format!("missions[{k}]"),
                    format!(
                        "must be 1..={} ids in 1..{}",
                        MAX_STATE_TOKENS,
                        vocab::VOCABULARY.len()
                    ),
                ));
            }
            if !seen.insert(m.as_slice()) {
                return Err(bad(format!("missions[{k}]"), "is listed twice".into()));
            }
        }
        let hid = self.model.lstm_hidden;
        for (k, e) in st.envs.iter().enumerate() {
            if e.h.len() != hid || e.c.len() != hid {
                return Err(bad(
                    format!("envs[{k}].h"),
                    format!(
                        "memory of length {}/{}, the model has {hid}",
                        e.h.len(),
                        e.c.len()
                    ),
                ));
            }
            if e.h.iter().chain(&e.c).any(|x| !x.is_finite()) {
                return Err(bad(
                    format!("envs[{k}].h"),
                    "holds NaN or infinite values".into(),
                ));
            }
            if !valid_tokens(&e.tokens) {
                return Err(bad(
                    format!("envs[{k}].tokens"),
                    format!(
                        "must be 1..={} ids in 1..{}",
                        MAX_STATE_TOKENS,
                        vocab::VOCABULARY.len()
                    ),
                ));
            }
            if e.mask != 0.0 && e.mask != 1.0 {
                return Err(bad(
                    format!("envs[{k}].mask"),
                    format!("{} is not 0 or 1", e.mask),
                ));
            }
            e.world
                .validate()
                .map_err(|err| bad(format!("envs[{k}].world"), err.to_string()))?;
            if e.world.ended() {
                return Err(bad(
                    format!("envs[{k}].world"),
                    "the episode has ended".into(),
                ));
            }
        }
        self.missions =
            super::missions::MissionCache::with_missions(std::mem::take(&mut st.missions));
        self.state = st;
        Ok(())
    }

    /// Adam's moments and step as named tensors (for the resume file), each of its
    /// parameter's shape.
    pub fn optimizer_tensors(&self) -> Result<BTreeMap<String, Tensor>, PolicyError> {
        let mut out = BTreeMap::new();
        for (k, mo) in &self.adam.moments {
            let shape = self
                .params
                .vars
                .get(k)
                .map(|v| v.as_tensor().shape().clone())
                .ok_or_else(|| PolicyError::Input(format!("no parameter {k} for its moments")))?;
            out.insert(
                format!("m.{k}"),
                Tensor::from_slice(&mo.m, shape.clone(), &Device::Cpu)?,
            );
            out.insert(
                format!("v.{k}"),
                Tensor::from_slice(&mo.v, shape, &Device::Cpu)?,
            );
        }
        Ok(out)
    }

    /// Restores Adam's moments and step.
    pub fn restore_optimizer(
        &mut self,
        tensors: &BTreeMap<String, Tensor>,
        step: u64,
    ) -> Result<(), PolicyError> {
        for (k, mo) in &mut self.adam.moments {
            let (Some(tm), Some(tv), Some(var)) = (
                tensors.get(&format!("m.{k}")),
                tensors.get(&format!("v.{k}")),
                self.params.vars.get(k),
            ) else {
                return Err(PolicyError::Input(format!(
                    "optimizer state lacks the moments of {k}"
                )));
            };
            let dims = var.as_tensor().dims();
            if tm.dims() != dims || tv.dims() != dims {
                return Err(PolicyError::Input(format!(
                    "optimizer moments of {k} have the wrong shape"
                )));
            }
            mo.m = tm.flatten_all()?.to_vec1()?;
            mo.v = tv.flatten_all()?.to_vec1()?;
        }
        self.adam.step = step;
        Ok(())
    }
}
