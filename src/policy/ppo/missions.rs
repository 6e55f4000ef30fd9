//! The rollout's mission inputs (the GRU code and the keyed queries), computed once per
//! distinct mission and update instead of at every step: a mission only changes when its
//! episode ends, and the GRU over every environment's words was 40% of a rollout step. The
//! missions met are remembered across updates, so that each rollout computes them all in
//! its first step, as one batch, instead of again whenever a new one turns up (which took a
//! third of a rollout's forward time).

use std::collections::HashMap;

use candle_core::{Device, Tensor};

use crate::policy::error::PolicyError;
use crate::policy::model::{MissionInputs, Net};
use crate::policy::obs::TokenBatch;

/// The distinct missions met so far and their inputs under the current rollout's weights
/// ([`MissionCache::renew`] at every rollout).
#[derive(Default)]
pub(super) struct MissionCache {
    /// Row of each distinct mission in `inputs`.
    ids: HashMap<Vec<u32>, u32>,
    /// The distinct missions, in row order.
    distinct: Vec<Vec<u32>>,
    /// The inputs of `distinct`, one row each; `None` until the first step or while a new
    /// mission has not been computed.
    inputs: Option<MissionInputs>,
}

/// Distinct missions kept at most; past that (a level with a vast mission space) the cache
/// starts again, so that a rollout does not compute missions it will never meet.
const MAX_DISTINCT: usize = 4096;

impl MissionCache {
    /// A cache that has met `distinct`, in that order (a resumed run's).
    pub(super) fn with_missions(distinct: Vec<Vec<u32>>) -> Self {
        let ids = distinct
            .iter()
            .enumerate()
            .map(|(row, m)| (m.clone(), row as u32))
            .collect();
        Self {
            ids,
            distinct,
            inputs: None,
        }
    }

    /// The distinct missions met, in row order.
    pub(super) fn distinct(&self) -> &[Vec<u32>] {
        &self.distinct
    }

    /// Forgets the inputs (the weights changed) but keeps the missions, which the next
    /// [`Self::inputs`] computes as one batch.
    pub(super) fn renew(&mut self) {
        self.inputs = None;
        if self.distinct.len() > MAX_DISTINCT {
            *self = Self::default();
        }
    }

    /// The inputs of `missions`, row for row. A mission not seen before in this rollout has
    /// all distinct missions computed again as one batch: each row of the GRU, the queries
    /// and the key projection depends on its own mission alone, so a mission's row is the
    /// same whatever batch it is computed in.
    pub(super) fn inputs(
        &mut self,
        net: &Net,
        missions: &[&[u32]],
    ) -> Result<MissionInputs, PolicyError> {
        let mut rows = Vec::with_capacity(missions.len());
        for m in missions {
            let row = if let Some(&row) = self.ids.get(*m) {
                row
            } else {
                let row = u32::try_from(self.distinct.len())
                    .map_err(|_| PolicyError::Input("too many distinct missions".into()))?;
                self.ids.insert(m.to_vec(), row);
                self.distinct.push(m.to_vec());
                self.inputs = None;
                row
            };
            rows.push(row);
        }
        let inputs = if let Some(inputs) = self.inputs.take() {
            inputs
        } else {
            let all: Vec<&[u32]> = self.distinct.iter().map(Vec::as_slice).collect();
            net.mission_inputs_keyed(&TokenBatch::new(&all)?)?
        };
        let n = rows.len();
        let selected = inputs.select(&Tensor::from_vec(rows, n, &Device::Cpu)?);
        self.inputs = Some(inputs);
        selected
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::level::LevelConfig;
    use crate::env::vocab::tokenize;
    use crate::policy::model::Memory;
    use crate::policy::obs::CellCodes;
    use crate::policy::params::Params;
    use crate::policy::{ModelConfig, Variant};

    /// Steps through the cache give the very numbers of computing each step's missions on
    /// their own, while missions of several lengths come and go, and after a renewal under
    /// new weights (all missions met so far then computed as one batch).
    #[test]
    fn cached_missions_step_exactly_as_recomputed_ones() -> Result<(), Box<dyn std::error::Error>> {
        for variant in [Variant::Attention, Variant::Baseline] {
            let cfg = ModelConfig::new(variant);
            let worlds: Vec<_> = (0..40)
                .map(|s| LevelConfig::default().generate(s))
                .collect::<Result<_, _>>()?;
            let tokens: Vec<Vec<u32>> = worlds
                .iter()
                .map(|w| tokenize(&w.mission))
                .collect::<Result<_, _>>()?;
            let mut cache = MissionCache::default();
            for step in 0..16usize {
                // A new rollout with new weights every 8 steps.
                let net = Net::new(cfg, Params::init(&cfg, 3 + step as u64 / 8)?.detached())?;
                if step == 8 {
                    let met = cache.distinct.len();
                    cache.renew();
                    assert_eq!(cache.distinct.len(), met, "renewing keeps the missions");
                }
                // Four environments; each step brings in missions from further down the list.
                let idx: Vec<usize> = (0..4).map(|e| (e * 7 + step * 3) % worlds.len()).collect();
                let missions: Vec<&[u32]> = idx.iter().map(|&i| tokens[i].as_slice()).collect();
                let obs: Vec<_> = idx.iter().map(|&i| worlds[i].observe()).collect();
                let codes = CellCodes::new(&obs);
                let mem = Memory::zeros(4, cfg.lstm_hidden)?;
                let direct = net.mission_inputs_keyed(&TokenBatch::new(&missions)?)?;
                let cached = cache.inputs(&net, &missions)?;
                let (l1, v1, m1) = net.step_untraced(&codes, &direct, &mem)?;
                let (l2, v2, m2) = net.step_untraced(&codes, &cached, &mem)?;
                assert_eq!(l1.to_vec2::<f32>()?, l2.to_vec2::<f32>()?, "step {step}");
                assert_eq!(v1.to_vec1::<f32>()?, v2.to_vec1::<f32>()?, "step {step}");
                assert_eq!(
                    m1.h.to_vec2::<f32>()?,
                    m2.h.to_vec2::<f32>()?,
                    "step {step}"
                );
            }
            assert!(cache.distinct.len() > 20, "missions came and went");
        }
        Ok(())
    }
}
