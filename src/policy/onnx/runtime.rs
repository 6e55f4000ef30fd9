//! Running an ONNX graph with tract (pure Rust, no native library): loading with every check
//! of the contract, and batched steps.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use tract_onnx::prelude::*;

use super::bounds::Bounds;
use super::clock::{Clock, StepTimes};
use super::contract::{self, Meta};
use super::load::{
    Inputs, bad, build, check_inputs, check_outputs, one_line, operators, props, what_it_reads,
};
use super::maps::{graph_map, view_map};
use super::mission_cache::MissionCache;
use super::{MapOutputs, OnnxStep};
use crate::env::view::{Observation, VIEW_SIZE};
use crate::env::vocab;
use crate::panics::panic_line;
use crate::policy::error::PolicyError;

const N_CELLS: usize = VIEW_SIZE * VIEW_SIZE;

/// An ONNX policy ready to run: its metadata and an optimised tract plan with a symbolic batch
/// size and mission length.
pub struct OnnxAgent {
    /// The file it was loaded from.
    pub path: PathBuf,
    /// Its metadata.
    pub meta: Meta,
    plan: Arc<TypedRunnableModel>,
    /// The mission encoder cut from the graph, when it could be cut.
    missions: Option<MissionCache>,
    /// Every tensor's size in B and L, checked before a step runs (docs/onnx.md#limits).
    bounds: Bounds,
    inputs: Inputs,
    optional: [bool; 3],
    /// How many actions `logits` score: 7, or 3 (left, right, forward).
    actions: usize,
    tokens: Vec<Option<i64>>,
    clock: Clock,
}

impl std::fmt::Debug for OnnxAgent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OnnxAgent")
            .field("path", &self.path)
            .field("meta", &self.meta)
            .finish_non_exhaustive()
    }
}

/// The default-domain opsets tract 0.23 is tested against (its parser warns outside them).
pub const SUPPORTED_OPSETS: std::ops::RangeInclusive<i64> = 9..=18;

impl OnnxAgent {
    /// Loads `path`, checking the contract (docs/onnx.md) before tract builds the plan: the
    /// metadata, the inputs' and outputs' names, types and static sizes, and every operator.
    pub fn load(path: &Path) -> Result<Self, PolicyError> {
        let bytes = crate::files::read_regular(path).map_err(|e| PolicyError::Io {
            path: path.to_owned(),
            reason: e.to_string(),
        })?;
        if bytes.is_empty() {
            return Err(bad(path, "the file is empty (0 bytes), not an ONNX model"));
        }
        let onnx = tract_onnx::onnx();
        let proto = onnx
            .proto_model_for_read(&mut bytes.as_slice())
            .map_err(|e| bad(path, format!("not an ONNX model: {}", one_line(&e))))?;
        // tract is tested against opsets 9 to 18 and can panic on others: refuse them here.
        let opset = proto
            .opset_import
            .iter()
            .find(|o| o.domain.is_empty() || o.domain == "ai.onnx")
            .map_or(0, |o| o.version);
        if !SUPPORTED_OPSETS.contains(&opset) {
            return Err(bad(
                path,
                format!(
                    "ONNX opset {opset} is outside the opsets groundscope's runtime supports \
                     ({}–{}); export with opset_version=17 (docs/onnx.md)",
                    SUPPORTED_OPSETS.start(),
                    SUPPORTED_OPSETS.end()
                ),
            ));
        }
        let stem = path
            .file_stem()
            .map_or_else(|| "onnx".into(), |s| s.to_string_lossy().into_owned());
        let graph = proto
            .graph
            .as_ref()
            .ok_or_else(|| bad(path, "the model has no graph"))?;
        // Which of mission and memory it takes decides which metadata keys it needs.
        let reads = what_it_reads(path, graph)?;
        let meta = contract::meta(&props(path, &proto)?, &stem, reads).map_err(|e| bad(path, e))?;
        // A graph of the paper's level must know every word its missions use, checked here;
        // one of a registered level only the words its missions hold, checked as they come;
        // one that reads no mission none.
        let paper_words = reads.mission && meta.level.babyai.is_none();
        // The message, not the error's own "invalid input:" prefix a second time.
        let tokens = contract::token_map(&meta.vocabulary, paper_words).map_err(|e| match e {
            PolicyError::Input(m) => bad(path, m),
            e => e,
        })?;
        let inputs = check_inputs(path, graph, meta.memory_size, reads)?;
        let (optional, actions) = check_outputs(path, graph, meta.memory_size, reads)?;
        if inputs.overrides && !(optional[0] && optional[2]) {
            return Err(bad(
                path,
                "the graph takes combined_override but does not output word_maps and combined_map (docs/onnx.md#interventions)",
            ));
        }
        let mut ops = Vec::new();
        operators(graph, &mut ops);
        if let Some((op, node)) = ops
            .iter()
            .find(|(op, _)| !onnx.op_register.0.contains_key(*op))
        {
            let node = if node.is_empty() {
                String::new()
            } else {
                format!(" (node \"{node}\")")
            };
            return Err(bad(
                path,
                format!("operator {op}{node} is not supported by the ONNX runtime (tract)"),
            ));
        }
        super::bounds::check_constant_shapes(path, graph)?;
        // tract panics when an allocation fails; a graph that gets past the bounds and still
        // asks for more than there is ends as an error, not a crash.
        let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            build(path, &onnx, &proto, inputs, &meta, optional)
        }))
        .map_err(|p| {
            bad(
                path,
                format!("tract failed reading the graph: {}", panic_line(&*p)),
            )
        })??;
        Ok(Self {
            path: path.to_owned(),
            meta,
            plan: built.plan,
            missions: built.missions,
            bounds: built.bounds,
            inputs,
            optional,
            actions,
            tokens,
            clock: Clock::default(),
        })
    }

    /// How many actions the graph scores: MiniGrid's 7, or its first 3 (left, right,
    /// forward) for a graph whose `logits` are (B, 3).
    pub fn n_actions(&self) -> usize {
        self.actions
    }

    /// How the graph is shown: its metadata name and its file, `NAME (file.onnx)`; the file
    /// alone when the metadata names none (the name is then the file's stem).
    pub fn display_name(&self) -> String {
        let file = self.path.file_name().map_or_else(
            || self.path.display().to_string(),
            |f| f.to_string_lossy().into_owned(),
        );
        let stem = self.path.file_stem().map(|s| s.to_string_lossy());
        if stem.as_deref() == Some(self.meta.name.as_str()) {
            file
        } else {
            format!("{} ({file})", self.meta.name)
        }
    }

    /// The ids the graph receives for a mission of groundscope's token ids (its
    /// `groundscope.vocabulary`'s numbering; −1 for a word it lacks, which no step can run).
    pub fn graph_ids(&self, tokens: &[u32]) -> Vec<i64> {
        tokens
            .iter()
            .map(|&t| self.tokens.get(t as usize).copied().flatten().unwrap_or(-1))
            .collect()
    }

    /// Whether the graph takes the mission (a model without text reads none).
    pub fn reads_mission(&self) -> bool {
        self.inputs.reads.mission
    }

    /// Whether the graph has memory (`memory` in, `memory_out` out; M = 0 without).
    pub fn has_memory(&self) -> bool {
        self.inputs.reads.memory
    }

    /// Whether the graph outputs per-word maps.
    pub fn has_maps(&self) -> bool {
        self.optional[0]
    }

    /// Whether the graph outputs the word weights `w`.
    pub fn has_weights(&self) -> bool {
        self.optional[1]
    }

    /// Whether the graph takes the override inputs, so that `M` can be set.
    pub fn takes_overrides(&self) -> bool {
        self.inputs.overrides
    }

    /// Forgets every mission the encoder cut from the graph has encoded (for timing runs
    /// that should each start as a fresh process would).
    pub fn forget_missions(&self) {
        if let Some(cache) = &self.missions {
            cache.clear();
        }
    }

    /// Where the time of its steps went so far.
    pub fn step_times(&self) -> StepTimes {
        use std::sync::atomic::Ordering::Relaxed;
        let c = &self.clock;
        StepTimes {
            steps: c.steps.load(Relaxed),
            runs: c.runs.load(Relaxed),
            encoder_runs: c.encoder_runs.load(Relaxed),
            graph_secs: c.graph_ns.load(Relaxed) as f64 * 1e-9,
            step_secs: c.step_ns.load(Relaxed) as f64 * 1e-9,
        }
    }

    /// One step for B environments: `obs`, their agents' `directions` (0–3), missions (our
    /// token ids) and `memory` (B × M, row-major). Rows are run in groups of equal mission
    /// length (the contract has no padding) and put back in order. `overrides` (B × 49,
    /// agent-up `j = vy·7 + vx`) replaces each row's `M` through the graph's override inputs.
    pub fn step(
        &self,
        obs: &[Observation],
        directions: &[u8],
        missions: &[&[u32]],
        memory: &[f32],
        overrides: Option<&[f32]>,
    ) -> Result<OnnxStep, PolicyError> {
        let start = std::time::Instant::now();
        let out = self.step_timed(obs, directions, missions, memory, overrides);
        self.clock
            .steps
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Clock::add(&self.clock.step_ns, start);
        out
    }

    fn step_timed(
        &self,
        obs: &[Observation],
        directions: &[u8],
        missions: &[&[u32]],
        memory: &[f32],
        overrides: Option<&[f32]>,
    ) -> Result<OnnxStep, PolicyError> {
        let (b, m) = (obs.len(), self.meta.memory_size);
        if let Some(o) = overrides {
            if !self.inputs.overrides {
                return Err(bad(
                    &self.path,
                    "interventions on M need a graph that takes combined_override and override_weight (docs/onnx.md#interventions)",
                ));
            }
            if o.len() != b * N_CELLS {
                return Err(PolicyError::Input(format!(
                    "{} override values for a batch of {b}",
                    o.len()
                )));
            }
        }
        if missions.len() != b || directions.len() != b || memory.len() != b * m {
            return Err(PolicyError::Input(format!(
                "batch sizes differ: {b} observations, {} missions, {} directions, {} memory values for M = {m}",
                missions.len(),
                directions.len(),
                memory.len()
            )));
        }
        let mut out = OnnxStep {
            logits: vec![Vec::new(); b],
            values: vec![0.0; b],
            memory: vec![0.0; b * m],
            maps: self.has_maps().then(|| vec![MapOutputs::default(); b]),
        };
        // A graph that reads no mission runs every row at once.
        let key = |r: usize| {
            if self.reads_mission() {
                missions[r].len()
            } else {
                0
            }
        };
        let mut lengths: Vec<usize> = (0..b).map(key).collect();
        lengths.sort_unstable();
        lengths.dedup();
        for len in lengths {
            let rows: Vec<usize> = (0..b).filter(|&r| key(r) == len).collect();
            let group = Group {
                rows: &rows,
                obs,
                directions,
                missions,
                memory,
                overrides,
            };
            self.run_group(&group, &mut out)?;
        }
        Ok(out)
    }

    /// The graph's token ids of `rows`' missions, each `len` long, row after row; a word
    /// outside the graph's vocabulary is refused by name.
    fn mission_ids(
        &self,
        rows: &[usize],
        missions: &[&[u32]],
        len: usize,
    ) -> Result<Vec<i64>, PolicyError> {
        let mut ids = Vec::with_capacity(rows.len() * len);
        for &r in rows {
            for &t in missions[r] {
                let id = self
                    .tokens
                    .get(t as usize)
                    .copied()
                    .flatten()
                    .ok_or_else(|| {
                        bad(
                            &self.path,
                            format!(
                                "the mission word \"{}\" is not in the graph's vocabulary \
                                 (metadata groundscope.vocabulary)",
                                vocab::word(t).unwrap_or("?")
                            ),
                        )
                    })?;
                ids.push(id);
            }
        }
        Ok(ids)
    }

    fn run_group(&self, g: &Group<'_>, out: &mut OnnxStep) -> Result<(), PolicyError> {
        let Group {
            rows,
            obs,
            directions,
            missions,
            memory,
            overrides,
        } = *g;
        let (n, m) = (rows.len(), self.meta.memory_size);
        let reads = self.inputs.reads;
        // A graph that reads no mission has no L: its sizes are checked at L = 1.
        let len = if reads.mission {
            missions[rows[0]].len()
        } else {
            0
        };
        self.bounds
            .check(&self.path, n, if reads.mission { len } else { 1 })?;
        let mut image = Vec::with_capacity(n * N_CELLS * 3);
        for &r in rows {
            for col in &obs[r].image {
                for cell in col {
                    image.extend(cell.iter().map(|&c| i64::from(c)));
                }
            }
        }
        let shape = [n, VIEW_SIZE, VIEW_SIZE, 3];
        let image = if self.inputs.image_int {
            tract_ndarray::Array::from_shape_vec(shape, image)
                .map(Tensor::from)
                .map_err(|e| PolicyError::Input(e.to_string()))?
        } else {
            let f: Vec<f32> = image.iter().map(|&c| c as f32).collect();
            tract_ndarray::Array::from_shape_vec(shape, f)
                .map(Tensor::from)
                .map_err(|e| PolicyError::Input(e.to_string()))?
        };
        let ids = if reads.mission {
            self.mission_ids(rows, missions, len)?
        } else {
            Vec::new()
        };
        let cached = match &self.missions {
            Some(cache) => {
                let ran = std::time::Instant::now();
                let (extra, encoded) = cache.inputs(&ids, len).map_err(|e| {
                    bad(
                        &self.path,
                        format!("running the mission encoder: {}", one_line(&e)),
                    )
                })?;
                Clock::add(&self.clock.graph_ns, ran);
                if encoded {
                    self.clock
                        .encoder_runs
                        .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
                extra
            }
            None => TVec::new(),
        };
        let mut inputs: TVec<TValue> = tvec![image.into()];
        if reads.mission {
            let mission = tract_ndarray::Array::from_shape_vec([n, len], ids)
                .map(Tensor::from)
                .map_err(|e| PolicyError::Input(e.to_string()))?;
            inputs.push(mission.into());
        }
        if reads.memory {
            let mem: Vec<f32> = rows
                .iter()
                .flat_map(|&r| memory[r * m..(r + 1) * m].iter().copied())
                .collect();
            let mem = tract_ndarray::Array::from_shape_vec([n, m], mem)
                .map(Tensor::from)
                .map_err(|e| PolicyError::Input(e.to_string()))?;
            inputs.push(mem.into());
        }
        if self.inputs.direction {
            let d: Vec<i64> = rows.iter().map(|&r| i64::from(directions[r])).collect();
            inputs.push(Tensor::from(tract_ndarray::Array::from_vec(d)).into());
        }
        if self.inputs.overrides {
            let layout = self.meta.map_layout;
            let mut maps = vec![0f32; n * N_CELLS];
            let mut weight = vec![0f32; n];
            if let Some(o) = overrides {
                for (k, &r) in rows.iter().enumerate() {
                    graph_map(
                        &o[r * N_CELLS..][..N_CELLS],
                        layout,
                        &mut maps[k * N_CELLS..][..N_CELLS],
                    );
                    weight[k] = 1.0;
                }
            }
            let maps = tract_ndarray::Array::from_shape_vec([n, VIEW_SIZE, VIEW_SIZE], maps)
                .map(Tensor::from)
                .map_err(|e| PolicyError::Input(e.to_string()))?;
            inputs.push(maps.into());
            inputs.push(Tensor::from(tract_ndarray::Array::from_vec(weight)).into());
        }
        inputs.extend(cached);
        let ran = std::time::Instant::now();
        let outputs =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.plan.run(inputs)))
                .map_err(|p| {
                    bad(
                        &self.path,
                        format!("running the graph: {}", panic_line(&*p)),
                    )
                })?;
        clean_upper_registers();
        Clock::add(&self.clock.graph_ns, ran);
        self.clock
            .runs
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let outputs =
            outputs.map_err(|e| bad(&self.path, format!("running the graph: {}", one_line(&e))))?;
        let get = |i: usize, name: &str, per_row: usize| -> Result<Vec<f32>, PolicyError> {
            let t = outputs[i]
                .cast_to::<f32>()
                .map_err(|e| bad(&self.path, format!("output {name}: {}", one_line(&e))))?;
            let view = t
                .to_plain_array_view::<f32>()
                .map_err(|e| bad(&self.path, format!("output {name}: {}", one_line(&e))))?;
            let v: Vec<f32> = view.iter().copied().collect();
            if v.len() != n * per_row {
                return Err(bad(
                    &self.path,
                    format!(
                        "output {name} has shape {:?}; the contract wants {per_row} values per row of a batch of {n}",
                        outputs[i].shape()
                    ),
                ));
            }
            if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                return Err(bad(&self.path, format!("output {name} holds {x}")));
            }
            // Maps and weights are distributions: a negative one would be drawn, measured
            // and recorded as attention (grounding accuracies, entropies of ln of < 0).
            if (name.starts_with("word_") || name == "combined_map")
                && let Some(x) = v.iter().find(|x| **x < 0.0)
            {
                return Err(bad(
                    &self.path,
                    format!("output {name} holds {x}: attention values must be ≥ 0"),
                ));
            }
            Ok(v)
        };
        let actions = self.actions;
        let logits = get(0, "logits", actions)?;
        let values = get(1, "value", 1)?;
        // Without memory, M = 0: no memory_out, an empty memory per row.
        let new_mem = if reads.memory {
            get(2, "memory_out", m)?
        } else {
            Vec::new()
        };
        let mut next = if reads.memory { 3 } else { 2 };
        let mut take = |present: bool, name: &str, per_row: usize| {
            if !present {
                return Ok(None);
            }
            next += 1;
            get(next - 1, name, per_row).map(Some)
        };
        let word_maps = take(self.optional[0], "word_maps", len * N_CELLS)?;
        let weights = take(self.optional[1], "word_weights", len)?;
        let combined = take(self.optional[2], "combined_map", N_CELLS)?;
        for (k, &r) in rows.iter().enumerate() {
            out.logits[r] = logits[k * actions..(k + 1) * actions].to_vec();
            out.values[r] = values[k];
            out.memory[r * m..(r + 1) * m].copy_from_slice(&new_mem[k * m..(k + 1) * m]);
            if let Some(maps) = out.maps.as_mut() {
                let layout = self.meta.map_layout;
                maps[r] = MapOutputs {
                    words: word_maps.as_ref().map(|a| {
                        (0..len)
                            .map(|i| view_map(&a[(k * len + i) * N_CELLS..][..N_CELLS], layout))
                            .collect()
                    }),
                    weights: weights.as_ref().map(|w| w[k * len..(k + 1) * len].to_vec()),
                    combined: combined
                        .as_ref()
                        .map(|c| view_map(&c[k * N_CELLS..(k + 1) * N_CELLS], layout)),
                };
            }
        }
        Ok(())
    }
}

/// Clears the upper halves of the vector registers after tract's plan ran. Its hand-written
/// AVX-512 kernels return without `vzeroupper`, and while the upper state stays dirty every
/// later scalar floating-point instruction of this thread pays for it: `ln` took ~80 ns a call
/// instead of ~5 (docs/onnx.md#speed).
pub(super) fn clean_upper_registers() {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX (checked above), the only requirement of `vzeroupper`; it
        // changes no register a Rust value can live in across this call.
        #[expect(
            unsafe_code,
            reason = "an intrinsic for a CPU feature checked just above"
        )]
        unsafe {
            std::arch::x86_64::_mm256_zeroupper();
        }
    }
}

/// The rows of one mission length, and everything a step of them reads.
#[derive(Clone, Copy)]
struct Group<'a> {
    rows: &'a [usize],
    obs: &'a [Observation],
    directions: &'a [u8],
    missions: &'a [&'a [u32]],
    memory: &'a [f32],
    overrides: Option<&'a [f32]>,
}
