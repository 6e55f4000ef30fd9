//! Running an ONNX graph with tract (pure Rust, no native library): loading with every check
//! of the contract, and batched steps.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use tract_onnx::pb;
use tract_onnx::prelude::*;

use super::contract::{
    self, MapLayout, Meta, ONNX_FLOAT, ONNX_INT64, OPTIONAL_INPUTS, OPTIONAL_OUTPUTS, Props,
    REQUIRED_INPUTS, REQUIRED_OUTPUTS,
};
use super::{MapOutputs, OnnxStep};
use crate::env::view::{Observation, VIEW_SIZE};
use crate::env::vocab;
use crate::policy::error::PolicyError;
use crate::policy::trace::ViewMap;

const N_CELLS: usize = VIEW_SIZE * VIEW_SIZE;
const ACTIONS: usize = crate::env::world::Action::COUNT;

/// An ONNX policy ready to run: its metadata and an optimised tract plan with a symbolic batch
/// size and mission length.
pub struct OnnxAgent {
    /// The file it was loaded from.
    pub path: PathBuf,
    /// Its metadata.
    pub meta: Meta,
    plan: Arc<TypedRunnableModel>,
    inputs: Inputs,
    optional: [bool; 3],
    tokens: Vec<Option<i64>>,
    clock: Clock,
}

/// Where an agent's step time went, summed over its life (for `bench onnx`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepTimes {
    /// Calls of [`OnnxAgent::step`].
    pub steps: u64,
    /// Graph runs (one per mission length in a step).
    pub runs: u64,
    /// Seconds inside tract's plan.
    pub graph_secs: f64,
    /// Seconds in [`OnnxAgent::step`] in all: the graph, plus building its inputs and reading
    /// its outputs.
    pub step_secs: f64,
}

impl StepTimes {
    /// What was spent since `before` (an earlier reading of the same agent).
    #[must_use]
    pub fn since(&self, before: &Self) -> Self {
        Self {
            steps: self.steps - before.steps,
            runs: self.runs - before.runs,
            graph_secs: self.graph_secs - before.graph_secs,
            step_secs: self.step_secs - before.step_secs,
        }
    }
}

/// Nanosecond counters behind [`StepTimes`] (atomics: sweeps step one agent from threads).
#[derive(Debug, Default)]
struct Clock {
    steps: std::sync::atomic::AtomicU64,
    runs: std::sync::atomic::AtomicU64,
    graph_ns: std::sync::atomic::AtomicU64,
    step_ns: std::sync::atomic::AtomicU64,
}

impl Clock {
    fn add(counter: &std::sync::atomic::AtomicU64, since: std::time::Instant) {
        let ns = u64::try_from(since.elapsed().as_nanos()).unwrap_or(u64::MAX);
        counter.fetch_add(ns, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Which form and which optional inputs the graph takes.
#[derive(Clone, Copy, Debug)]
struct Inputs {
    /// `image` is int64 (else float).
    image_int: bool,
    /// It takes `direction`.
    direction: bool,
    /// It takes `combined_override` and `override_weight` (interventions on `M`).
    overrides: bool,
}

impl std::fmt::Debug for OnnxAgent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OnnxAgent")
            .field("path", &self.path)
            .field("meta", &self.meta)
            .finish_non_exhaustive()
    }
}

/// One line naming the file.
fn bad(path: &Path, what: impl std::fmt::Display) -> PolicyError {
    PolicyError::Input(format!("{}: {what}", path.display()))
}

/// tract's error chain on one line.
fn one_line(e: &anyhow::Error) -> String {
    format!("{e:#}").replace('\n', " ")
}

/// The declared element type and static dimensions (`None` for a symbolic one) of a value.
fn declared(v: &pb::ValueInfoProto) -> (Option<i32>, Option<Vec<Option<i64>>>) {
    let Some(pb::type_proto::Value::TensorType(t)) =
        v.r#type.as_ref().and_then(|t| t.value.as_ref())
    else {
        return (None, None);
    };
    let dims = t.shape.as_ref().map(|s| {
        s.dim
            .iter()
            .map(|d| match d.value {
                Some(pb::tensor_shape_proto::dimension::Value::DimValue(n)) => Some(n),
                _ => None,
            })
            .collect()
    });
    (Some(t.elem_type), dims)
}

fn type_name(code: i32) -> String {
    match code {
        ONNX_FLOAT => "float32".into(),
        ONNX_INT64 => "int64".into(),
        2 => "uint8".into(),
        6 => "int32".into(),
        11 => "float64".into(),
        other => format!("ONNX type {other}"),
    }
}

/// Every operator of `graph` and its subgraphs (a `Loop`'s body, an `If`'s branches).
fn operators<'a>(graph: &'a pb::GraphProto, out: &mut Vec<(&'a str, &'a str)>) {
    for node in &graph.node {
        out.push((node.op_type.as_str(), node.name.as_str()));
        for a in &node.attribute {
            if let Some(g) = &a.g {
                operators(g, out);
            }
            for g in &a.graphs {
                operators(g, out);
            }
        }
    }
}

/// The metadata: the protobuf's `groundscope.*` keys, overridden by a sidecar `FILE.json`.
fn props(path: &Path, proto: &pb::ModelProto) -> Result<Props, PolicyError> {
    let mut props: Props = proto
        .metadata_props
        .iter()
        .filter_map(|e| {
            Some((
                e.key.strip_prefix("groundscope.")?.to_owned(),
                e.value.clone(),
            ))
        })
        .collect();
    let mut sidecar = path.as_os_str().to_owned();
    sidecar.push(".json");
    let sidecar = PathBuf::from(sidecar);
    if sidecar.exists() {
        let text = std::fs::read_to_string(&sidecar).map_err(|e| PolicyError::Io {
            path: sidecar.clone(),
            reason: e.to_string(),
        })?;
        let map: serde_json::Map<String, serde_json::Value> = serde_json::from_str(&text)
            .map_err(|e| bad(&sidecar, format!("not a JSON object of metadata: {e}")))?;
        for (k, v) in map {
            let v = match v {
                serde_json::Value::String(s) => s,
                other => other.to_string(),
            };
            props.insert(k, v);
        }
    }
    Ok(props)
}

impl OnnxAgent {
    /// Loads `path`, checking the contract (docs/onnx.md) before tract builds the plan: the
    /// metadata, the inputs' and outputs' names, types and static sizes, and every operator.
    pub fn load(path: &Path) -> Result<Self, PolicyError> {
        let bytes = std::fs::read(path).map_err(|e| PolicyError::Io {
            path: path.to_owned(),
            reason: e.to_string(),
        })?;
        let onnx = tract_onnx::onnx();
        let proto = onnx
            .proto_model_for_read(&mut bytes.as_slice())
            .map_err(|e| bad(path, format!("not an ONNX model: {}", one_line(&e))))?;
        let stem = path
            .file_stem()
            .map_or_else(|| "onnx".into(), |s| s.to_string_lossy().into_owned());
        let meta = contract::meta(&props(path, &proto)?, &stem).map_err(|e| bad(path, e))?;
        let tokens = contract::token_map(&meta.vocabulary).map_err(|e| bad(path, e))?;
        let graph = proto
            .graph
            .as_ref()
            .ok_or_else(|| bad(path, "the model has no graph"))?;
        let inputs = check_inputs(path, graph, meta.memory_size)?;
        let optional = check_outputs(path, graph, meta.memory_size)?;
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
        let plan = build(path, &onnx, &proto, inputs, &meta, optional)?;
        Ok(Self {
            path: path.to_owned(),
            meta,
            plan,
            inputs,
            optional,
            tokens,
            clock: Clock::default(),
        })
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

    /// Where the time of its steps went so far.
    pub fn step_times(&self) -> StepTimes {
        use std::sync::atomic::Ordering::Relaxed;
        let c = &self.clock;
        StepTimes {
            steps: c.steps.load(Relaxed),
            runs: c.runs.load(Relaxed),
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
        let mut lengths: Vec<usize> = missions.iter().map(|t| t.len()).collect();
        lengths.sort_unstable();
        lengths.dedup();
        for len in lengths {
            let rows: Vec<usize> = (0..b).filter(|&r| missions[r].len() == len).collect();
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
        let len = missions[rows[0]].len();
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
        let mut ids = Vec::with_capacity(n * len);
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
                                "metadata groundscope.vocabulary has no word \"{}\"",
                                vocab::word(t).unwrap_or("?")
                            ),
                        )
                    })?;
                ids.push(id);
            }
        }
        let mission = tract_ndarray::Array::from_shape_vec([n, len], ids)
            .map(Tensor::from)
            .map_err(|e| PolicyError::Input(e.to_string()))?;
        let mem: Vec<f32> = rows
            .iter()
            .flat_map(|&r| memory[r * m..(r + 1) * m].iter().copied())
            .collect();
        let mem = tract_ndarray::Array::from_shape_vec([n, m], mem)
            .map(Tensor::from)
            .map_err(|e| PolicyError::Input(e.to_string()))?;
        let mut inputs: TVec<TValue> = tvec![image.into(), mission.into(), mem.into()];
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
        let ran = std::time::Instant::now();
        let outputs = self.plan.run(inputs);
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
            Ok(v)
        };
        let logits = get(0, "logits", ACTIONS)?;
        let values = get(1, "value", 1)?;
        let new_mem = get(2, "memory_out", m)?;
        let mut next = 3;
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
            out.logits[r] = logits[k * ACTIONS..(k + 1) * ACTIONS].to_vec();
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
fn clean_upper_registers() {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX (checked above), the only requirement of `vzeroupper`; it
        // changes no register a Rust value can live in across this call.
        #[expect(unsafe_code, reason = "an intrinsic for a CPU feature checked just above")]
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

/// 49 agent-up values (`j = vy·7 + vx`) → the graph's layout, into `out`.
fn graph_map(v: &[f32], layout: MapLayout, out: &mut [f32]) {
    for (j, x) in v.iter().enumerate().take(N_CELLS) {
        let (vy, vx) = (j / VIEW_SIZE, j % VIEW_SIZE);
        match layout {
            MapLayout::Image => out[vx * VIEW_SIZE + vy] = *x,
            MapLayout::AgentUp => out[j] = *x,
        }
    }
}

/// 49 values in the graph's layout → an agent-up map (`map[vy][vx]`).
fn view_map(v: &[f32], layout: MapLayout) -> ViewMap {
    let mut map = [[0.0; VIEW_SIZE]; VIEW_SIZE];
    for (j, x) in v.iter().enumerate().take(N_CELLS) {
        let (a, b) = (j / VIEW_SIZE, j % VIEW_SIZE);
        match layout {
            MapLayout::Image => map[b][a] = *x,
            MapLayout::AgentUp => map[a][b] = *x,
        }
    }
    map
}

/// Checks the inputs' names, types and static sizes; returns which form and which optional
/// inputs the graph takes.
fn check_inputs(
    path: &Path,
    graph: &pb::GraphProto,
    memory_size: usize,
) -> Result<Inputs, PolicyError> {
    let init: std::collections::HashSet<&str> =
        graph.initializer.iter().map(|t| t.name.as_str()).collect();
    let inputs: Vec<&pb::ValueInfoProto> = graph
        .input
        .iter()
        .filter(|v| !init.contains(v.name.as_str()))
        .collect();
    let find = |name: &str| inputs.iter().find(|v| v.name == name);
    for name in REQUIRED_INPUTS {
        if find(name).is_none() {
            return Err(bad(
                path,
                format!(
                    "the graph has no input \"{name}\" (the contract's inputs: image, mission, memory and optionally direction)"
                ),
            ));
        }
    }
    if let Some(extra) = inputs.iter().find(|v| {
        !REQUIRED_INPUTS.contains(&v.name.as_str()) && !OPTIONAL_INPUTS.contains(&v.name.as_str())
    }) {
        return Err(bad(
            path,
            format!("input \"{}\" is not in the contract", extra.name),
        ));
    }
    let m = memory_size as i64;
    let mut image_int = false;
    for v in &inputs {
        let (ty, dims) = declared(v);
        let (types, rank, fixed): (&[i32], usize, &[(usize, i64)]) = match v.name.as_str() {
            "image" => (&[ONNX_FLOAT, ONNX_INT64], 4, &[(1, 7), (2, 7), (3, 3)]),
            "mission" => (&[ONNX_INT64], 2, &[]),
            "memory" => (&[ONNX_FLOAT], 2, &[]),
            "combined_override" => (&[ONNX_FLOAT], 3, &[(1, 7), (2, 7)]),
            "override_weight" => (&[ONNX_FLOAT], 1, &[]),
            _ => (&[ONNX_INT64], 1, &[]),
        };
        if let Some(ty) = ty
            && !types.contains(&ty)
        {
            let want: Vec<String> = types.iter().map(|&t| type_name(t)).collect();
            return Err(bad(
                path,
                format!(
                    "input \"{}\" is {}; the contract wants {}",
                    v.name,
                    type_name(ty),
                    want.join(" or ")
                ),
            ));
        }
        if v.name == "image" {
            image_int = ty == Some(ONNX_INT64);
        }
        let mut fixed = fixed.to_vec();
        if v.name == "memory" {
            fixed.push((1, m));
        }
        check_dims(path, "input", &v.name, dims.as_deref(), rank, &fixed)?;
    }
    let overrides = match (
        find("combined_override").is_some(),
        find("override_weight").is_some(),
    ) {
        (true, true) => true,
        (false, false) => false,
        (has, _) => {
            let (given, missing) = if has {
                ("combined_override", "override_weight")
            } else {
                ("override_weight", "combined_override")
            };
            return Err(bad(
                path,
                format!(
                    "the graph takes \"{given}\" but not \"{missing}\"; the contract wants both or neither"
                ),
            ));
        }
    };
    Ok(Inputs {
        image_int,
        direction: find("direction").is_some(),
        overrides,
    })
}

/// Checks a declared shape's rank and static sizes, where the graph declares them.
fn check_dims(
    path: &Path,
    kind: &str,
    name: &str,
    dims: Option<&[Option<i64>]>,
    rank: usize,
    fixed: &[(usize, i64)],
) -> Result<(), PolicyError> {
    let Some(dims) = dims else { return Ok(()) };
    let shown = || {
        let d: Vec<String> = dims
            .iter()
            .map(|d| d.map_or_else(|| "?".into(), |n| n.to_string()))
            .collect();
        format!("({})", d.join(", "))
    };
    if dims.len() != rank {
        return Err(bad(
            path,
            format!(
                "{kind} \"{name}\" has shape {}; the contract wants {rank} dimensions",
                shown()
            ),
        ));
    }
    for &(axis, size) in fixed {
        if let Some(Some(n)) = dims.get(axis)
            && *n != size
        {
            return Err(bad(
                path,
                format!(
                    "{kind} \"{name}\" has shape {}; the contract wants {size} on axis {axis}",
                    shown()
                ),
            ));
        }
    }
    Ok(())
}

/// Checks the outputs; returns which optional ones are present.
fn check_outputs(
    path: &Path,
    graph: &pb::GraphProto,
    memory_size: usize,
) -> Result<[bool; 3], PolicyError> {
    let find = |name: &str| graph.output.iter().find(|v| v.name == name);
    for name in REQUIRED_OUTPUTS {
        let Some(v) = find(name) else {
            return Err(bad(
                path,
                format!(
                    "the graph has no output \"{name}\" (the contract's outputs: logits, value, memory_out)"
                ),
            ));
        };
        let (ty, dims) = declared(v);
        if let Some(ty) = ty
            && ty != ONNX_FLOAT
        {
            return Err(bad(
                path,
                format!(
                    "output \"{name}\" is {}; the contract wants float32",
                    type_name(ty)
                ),
            ));
        }
        match name {
            "logits" => check_dims(path, "output", name, dims.as_deref(), 2, &[(1, 7)])?,
            "memory_out" => check_dims(
                path,
                "output",
                name,
                dims.as_deref(),
                2,
                &[(1, memory_size as i64)],
            )?,
            _ => {}
        }
    }
    Ok(OPTIONAL_OUTPUTS.map(|name| find(name).is_some()))
}

/// Builds the optimised plan: inputs in the order image, mission, memory (, direction) with a
/// symbolic batch `B` and mission length `L`; outputs the required ones, then the optional
/// ones present.
fn build(
    path: &Path,
    onnx: &tract_onnx::Onnx,
    proto: &pb::ModelProto,
    given: Inputs,
    meta: &Meta,
    optional: [bool; 3],
) -> Result<Arc<TypedRunnableModel>, PolicyError> {
    let fail = |e: anyhow::Error| bad(path, format!("tract: {}", one_line(&e)));
    let mut model = onnx.model_for_proto_model(proto).map_err(fail)?;
    let mut inputs = vec!["image", "mission", "memory"];
    if given.direction {
        inputs.push("direction");
    }
    if given.overrides {
        inputs.extend(["combined_override", "override_weight"]);
    }
    model.set_input_names(&inputs).map_err(fail)?;
    let (b, l) = (model.symbols.sym("B"), model.symbols.sym("L"));
    let image_type = if given.image_int {
        i64::datum_type()
    } else {
        f32::datum_type()
    };
    let mut facts = vec![
        InferenceFact::dt_shape(image_type, [b.to_dim(), 7.to_dim(), 7.to_dim(), 3.to_dim()]),
        InferenceFact::dt_shape(i64::datum_type(), [b.to_dim(), l.to_dim()]),
        InferenceFact::dt_shape(f32::datum_type(), [b.to_dim(), meta.memory_size.to_dim()]),
    ];
    if given.direction {
        facts.push(InferenceFact::dt_shape(i64::datum_type(), [b.to_dim()]));
    }
    if given.overrides {
        facts.push(InferenceFact::dt_shape(
            f32::datum_type(),
            [b.to_dim(), 7.to_dim(), 7.to_dim()],
        ));
        facts.push(InferenceFact::dt_shape(f32::datum_type(), [b.to_dim()]));
    }
    for (i, fact) in facts.into_iter().enumerate() {
        model.set_input_fact(i, fact).map_err(fail)?;
    }
    let mut outputs: Vec<&str> = REQUIRED_OUTPUTS.to_vec();
    outputs.extend(
        OPTIONAL_OUTPUTS
            .iter()
            .zip(optional)
            .filter(|(_, on)| *on)
            .map(|(n, _)| *n),
    );
    model.select_outputs_by_name(&outputs).map_err(fail)?;
    model
        .into_optimized()
        .and_then(IntoRunnable::into_runnable)
        .map_err(fail)
}
