//! Runs the part of an imported graph that reads only the mission once per mission.
//!
//! A policy's text encoder (word embeddings, a GRU over the words, the attention's queries)
//! depends on the mission alone, which stays the same for a whole episode; the contract's one
//! graph per step would re-run it at every step (a fifth of the bundled model's export's time,
//! docs/onnx.md#speed). At load, the graph is cut where the nodes that depend on the mission
//! and on nothing else (but constants) feed the rest: the **encoder** (the `mission` input →
//! those tensors) runs for each mission not seen before, its outputs are kept per mission, and
//! the **step** graph takes them as extra inputs, stacked for the rows of a batch. Nothing is
//! cut when there is nothing to cut, or when a cut tensor has no single batch axis (it could
//! not be kept per row): the graph then runs whole, as before.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use tract_onnx::prelude::*;
use tract_onnx::tract_core::ops::source::TypedSource;

/// Missions kept at most; the cache starts over when it would hold more.
const KEPT: usize = 65_536;

/// The two graphs of a cut model, not yet optimised.
pub(super) struct Parts {
    /// `mission` → the cut tensors.
    pub encoder: TypedModel,
    /// The original inputs, then one input per cut tensor.
    pub step: TypedModel,
    /// Each cut tensor's batch axis.
    pub axes: Vec<usize>,
}

/// Cuts `model` (its input `mission_input` is the mission; `batch` the batch-size symbol) into
/// an encoder and a step graph, or `None` when it cannot be or need not be cut.
pub(super) fn cut(
    model: &TypedModel,
    mission_input: usize,
    batch: &Symbol,
) -> TractResult<Option<Parts>> {
    let mission = model.input_outlets()?[mission_input];
    let order = model.eval_order()?;
    let n = model.nodes.len();
    let mut in_order = vec![false; n];
    let mut reads = vec![false; n]; // depends on the mission
    let mut only = vec![false; n]; // depends on nothing but the mission and constants
    for &id in &order {
        in_order[id] = true;
        let node = &model.nodes[id];
        if id == mission.node {
            reads[id] = true;
            only[id] = true;
        } else if !node.op_is::<TypedSource>() {
            reads[id] = node.inputs.iter().any(|i| reads[i.node]);
            only[id] = node.inputs.iter().all(|i| only[i.node]);
        }
    }
    let outputs = model.output_outlets()?;
    let leaves = |o: OutletId| {
        outputs.contains(&o)
            || model
                .outlet_successors(o)
                .iter()
                .any(|s| in_order[s.node] && !only[s.node])
    };
    let mut cut = Vec::new();
    for &id in &order {
        if id == mission.node || !(reads[id] && only[id]) {
            continue;
        }
        for slot in 0..model.nodes[id].outputs.len() {
            let o = OutletId::new(id, slot);
            if leaves(o) {
                cut.push(o);
            }
        }
    }
    if cut.is_empty() {
        return Ok(None);
    }
    let mut axes = Vec::with_capacity(cut.len());
    for &o in &cut {
        let fact = model.outlet_fact(o)?;
        if fact.datum_type == TDim::datum_type() {
            return Ok(None);
        }
        let on_batch: Vec<usize> = (0..fact.rank())
            .filter(|&i| fact.shape[i].symbols().contains(batch))
            .collect();
        match on_batch[..] {
            [i] if fact.shape[i] == batch.to_dim() => axes.push(i),
            _ => return Ok(None),
        }
    }
    let mut encoder = model.clone();
    encoder.set_input_outlets(&[mission])?;
    encoder.select_output_outlets(&cut)?;
    encoder.compact()?;
    let mut step = model.clone();
    let mut step_outputs = outputs.to_vec();
    for (i, &o) in cut.iter().enumerate() {
        let src = step.add_source(
            format!("groundscope.mission_cache.{i}"),
            model.outlet_fact(o)?.clone(),
        )?;
        for &s in model.outlet_successors(o) {
            if in_order[s.node] && !only[s.node] {
                step.add_edge(src, s)?;
            }
        }
        for out in &mut step_outputs {
            if *out == o {
                *out = src;
            }
        }
    }
    step.select_output_outlets(&step_outputs)?;
    step.compact()?;
    Ok(Some(Parts {
        encoder,
        step,
        axes,
    }))
}

/// The encoder of a cut graph and what it computed, per mission.
pub(super) struct MissionCache {
    encoder: Arc<TypedRunnableModel>,
    axes: Vec<usize>,
    kept: Mutex<HashMap<Vec<i64>, Vec<Tensor>>>,
}

impl MissionCache {
    /// A cache over this (optimised) encoder, whose outputs have these batch axes.
    pub(super) fn new(encoder: Arc<TypedRunnableModel>, axes: Vec<usize>) -> Self {
        Self {
            encoder,
            axes,
            kept: Mutex::new(HashMap::new()),
        }
    }

    /// Forgets every kept mission.
    pub(super) fn clear(&self) {
        if let Ok(mut kept) = self.kept.lock() {
            kept.clear();
        }
    }

    /// The step graph's extra inputs for a batch whose missions are `ids` (rows of `len`
    /// token ids, row-major): the encoder runs once on the missions it has not seen, and
    /// each cut tensor is stacked row by row. Returns them and whether the encoder ran.
    pub(super) fn inputs(&self, ids: &[i64], len: usize) -> TractResult<(TVec<TValue>, bool)> {
        let mut kept = self
            .kept
            .lock()
            .map_err(|_| anyhow::anyhow!("the mission cache was poisoned by a panic"))?;
        let unseen = |kept: &HashMap<Vec<i64>, Vec<Tensor>>| {
            let mut missing: Vec<&[i64]> = Vec::new();
            for m in ids.chunks(len) {
                if !kept.contains_key(m) && !missing.contains(&m) {
                    missing.push(m);
                }
            }
            missing
        };
        let mut missing = unseen(&kept);
        if kept.len() + missing.len() > KEPT {
            // Starting over forgets this batch's kept missions too: encode all of them.
            kept.clear();
            missing = unseen(&kept);
        }
        let ran = !missing.is_empty();
        if ran {
            let flat: Vec<i64> = missing.concat();
            let batch = Tensor::from_shape(&[missing.len(), len], &flat)?;
            let out = self.encoder.run(tvec![batch.into()]);
            super::runtime::clean_upper_registers();
            let out = out?;
            for (r, m) in missing.iter().enumerate() {
                let row = out
                    .iter()
                    .zip(&self.axes)
                    .map(|(t, &axis)| t.slice(axis, r, r + 1))
                    .collect::<TractResult<Vec<_>>>()?;
                kept.insert(m.to_vec(), row);
            }
        }
        let mut stacked = TVec::new();
        for (k, &axis) in self.axes.iter().enumerate() {
            let rows: Vec<&Tensor> = ids
                .chunks(len)
                .map(|m| {
                    kept.get(m)
                        .map(|row| &row[k])
                        .ok_or_else(|| anyhow::anyhow!("mission missing from the cache"))
                })
                .collect::<TractResult<_>>()?;
            stacked.push(Tensor::stack_tensors(axis, &rows)?.into());
        }
        Ok((stacked, ran))
    }
}
