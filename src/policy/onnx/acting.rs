//! An imported graph behind the acting interface ([`crate::policy::Acting`]); without the
//! `onnx` feature every call is a one-line error.

#[cfg(feature = "onnx")]
use crate::env::view::Observation;
use crate::policy::ActOutput;
use crate::policy::acting::{Acting, Step};
#[cfg(feature = "onnx")]
use crate::policy::acting::{flat_memory, flat_memory_rows, softmax};
#[cfg(feature = "onnx")]
use crate::policy::attention::Intervention;
use crate::policy::config::Variant;
use crate::policy::error::PolicyError;
use crate::policy::model::{Memory, MissionInputs};

#[cfg(feature = "onnx")]
impl Acting for super::OnnxAgent {
    fn model_name(&self) -> Option<String> {
        Some(self.display_name())
    }

    fn input_token_ids(&self, tokens: &[u32]) -> Option<Vec<i64>> {
        // A graph that reads no mission receives no ids, and no word is unknown to it.
        self.reads_mission().then(|| self.graph_ids(tokens))
    }

    fn variant(&self) -> Variant {
        if self.has_maps() {
            Variant::Attention
        } else {
            Variant::Baseline
        }
    }

    fn zero_memory(&self) -> Result<Memory, PolicyError> {
        flat_memory(vec![0.0; self.meta.memory_size])
    }

    fn prepare(&self, _tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError> {
        Ok(None)
    }

    fn zero_memory_batch(&self, batch: usize) -> Result<Memory, PolicyError> {
        flat_memory_rows(vec![0.0; batch * self.meta.memory_size], batch)
    }

    fn prepare_batch(&self, _missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError> {
        Ok(None)
    }

    fn act_step(&self, step: &Step<'_>) -> Result<ActOutput, PolicyError> {
        let (obs, directions, missions) = (step.obs, step.directions, step.missions);
        let (memory, with_traces) = (step.memory, step.traces);
        let mem = memory.h.flatten_all()?.to_vec1::<f32>()?;
        let overrides = match step.intervention {
            None => None,
            Some(iv) => Some(self.overrides(obs, directions, missions, &mem, iv)?),
        };
        let step = self.step(obs, directions, missions, &mem, overrides.as_deref())?;
        let traces = match (&step.maps, with_traces) {
            (Some(maps), true) => Some(
                missions
                    .iter()
                    .zip(maps)
                    .map(|(t, m)| super::trace(t, m))
                    .collect::<Result<Vec<_>, _>>()?,
            ),
            _ => None,
        };
        let logits = step.logits;
        Ok(ActOutput {
            probs: logits.iter().map(|l| softmax(l)).collect(),
            logits,
            values: step.values,
            memory: flat_memory_rows(step.memory, obs.len())?,
            traces,
        })
    }

    fn takes_interventions(&self) -> bool {
        self.takes_overrides()
    }

    fn n_actions(&self) -> usize {
        super::OnnxAgent::n_actions(self)
    }
}

#[cfg(feature = "onnx")]
impl super::OnnxAgent {
    /// The `M` each row gets under `iv` (B × 49, agent-up): the given maps for
    /// [`Intervention::SetM`]; for [`Intervention::ScaleWeights`] the graph's own word maps
    /// recombined with its weights scaled and renormalised — the native model's definition
    /// (`attention::attend_with`), from one unperturbed forward.
    fn overrides(
        &self,
        obs: &[Observation],
        directions: &[u8],
        missions: &[&[u32]],
        memory: &[f32],
        iv: &Intervention,
    ) -> Result<Vec<f32>, PolicyError> {
        let factors = match iv {
            Intervention::SetM(m) => return Ok(m.flatten_all()?.to_vec1::<f32>()?),
            Intervention::ScaleWeights(f) => f.to_vec2::<f32>()?,
        };
        if !self.has_weights() {
            return Err(PolicyError::Input(format!(
                "{}: scaling the word weights needs a graph that outputs word_weights",
                self.path.display()
            )));
        }
        let base = self.step(obs, directions, missions, memory, None)?;
        let maps = base.maps.unwrap_or_default();
        let mut out = vec![0f32; obs.len() * crate::policy::obs::N_CELLS];
        for (r, (m, f)) in maps.iter().zip(&factors).enumerate() {
            let (Some(words), Some(w)) = (&m.words, &m.weights) else {
                continue;
            };
            let scaled: Vec<f32> = w.iter().zip(f).map(|(w, f)| w * f).collect();
            let total = scaled.iter().sum::<f32>().max(1e-30);
            let renormalised: Vec<f32> = scaled.iter().map(|x| x / total).collect();
            let m = super::combine(words, &renormalised);
            out[r * crate::policy::obs::N_CELLS..][..crate::policy::obs::N_CELLS]
                .copy_from_slice(m.as_flattened());
        }
        Ok(out)
    }
}

/// What every call of an imported graph answers in a build without the `onnx` feature.
#[cfg(not(feature = "onnx"))]
fn unbuilt() -> PolicyError {
    PolicyError::Input("built without the onnx feature".into())
}

#[cfg(not(feature = "onnx"))]
impl Acting for super::OnnxAgent {
    fn variant(&self) -> Variant {
        Variant::Baseline
    }

    fn zero_memory(&self) -> Result<Memory, PolicyError> {
        Err(unbuilt())
    }

    fn prepare(&self, _tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError> {
        Err(unbuilt())
    }

    fn act_step(&self, _step: &Step<'_>) -> Result<ActOutput, PolicyError> {
        Err(unbuilt())
    }

    fn zero_memory_batch(&self, _batch: usize) -> Result<Memory, PolicyError> {
        Err(unbuilt())
    }

    fn prepare_batch(&self, _missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError> {
        Err(unbuilt())
    }

    fn takes_interventions(&self) -> bool {
        false
    }
}
