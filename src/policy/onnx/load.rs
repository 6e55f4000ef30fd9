//! Reading an ONNX file: every check of the contract (docs/onnx.md) on the graph as written —
//! metadata, inputs, outputs, operators — and building tract's optimised plans from it.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use tract_onnx::pb;
use tract_onnx::prelude::*;

use super::bounds::Bounds;
use super::contract::{
    MEMORY_OUTPUT, Meta, ONNX_FLOAT, ONNX_INT64, OPTIONAL_INPUTS, OPTIONAL_OUTPUTS, Props,
    REQUIRED_INPUTS, REQUIRED_OUTPUTS, Reads, STATE_INPUTS, logits_width,
};
use super::mission_cache::MissionCache;
use crate::policy::error::PolicyError;

/// Which form and which optional inputs the graph takes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Inputs {
    /// `image` is int64 (else float).
    pub(super) image_int: bool,
    /// It takes `direction`.
    pub(super) direction: bool,
    /// It takes `combined_override` and `override_weight` (interventions on `M`).
    pub(super) overrides: bool,
    /// It takes `mission` and `memory` (with `memory_out`), where the model reads them.
    pub(super) reads: Reads,
}

/// The graph's inputs, initializers left out (an exporter may list its weights as inputs).
fn graph_inputs(graph: &pb::GraphProto) -> Vec<&pb::ValueInfoProto> {
    let init: std::collections::HashSet<&str> =
        graph.initializer.iter().map(|t| t.name.as_str()).collect();
    graph
        .input
        .iter()
        .filter(|v| !init.contains(v.name.as_str()))
        .collect()
}

/// Whether the graph reads a mission and has memory, read from its inputs and outputs before
/// its metadata (which keys it needs depends on them): memory is `memory` in and `memory_out`
/// out, both or neither, else one line naming the one missing.
pub(super) fn what_it_reads(path: &Path, graph: &pb::GraphProto) -> Result<Reads, PolicyError> {
    let inputs = graph_inputs(graph);
    let takes = |name: &str| inputs.iter().any(|v| v.name == name);
    let outputs = graph.output.iter().any(|v| v.name == MEMORY_OUTPUT);
    let pair = "a graph with memory takes \"memory\" and outputs \"memory_out\", one without \
                memory has neither (docs/onnx.md#inputs)";
    match (takes("memory"), outputs) {
        (true, false) => Err(bad(
            path,
            format!("the graph takes \"memory\" but has no output \"memory_out\"; {pair}"),
        )),
        (false, true) => Err(bad(
            path,
            format!("the graph outputs \"memory_out\" but has no input \"memory\"; {pair}"),
        )),
        (memory, _) => Ok(Reads {
            mission: takes("mission"),
            memory,
        }),
    }
}

/// One line naming the file.
pub(super) fn bad(path: &Path, what: impl std::fmt::Display) -> PolicyError {
    PolicyError::Input(format!("{}: {what}", path.display()))
}

/// tract's error chain on one line.
pub(super) fn one_line(e: &anyhow::Error) -> String {
    format!("{e:#}").replace('\n', " ")
}

/// The declared element type and static dimensions (`None` for a symbolic one) of a value.
pub(super) fn declared(v: &pb::ValueInfoProto) -> (Option<i32>, Option<Vec<Option<i64>>>) {
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

pub(super) fn type_name(code: i32) -> String {
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
pub(super) fn operators<'a>(graph: &'a pb::GraphProto, out: &mut Vec<(&'a str, &'a str)>) {
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
pub(super) fn props(path: &Path, proto: &pb::ModelProto) -> Result<Props, PolicyError> {
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
        let text = crate::files::read_regular_to_string(&sidecar).map_err(|e| PolicyError::Io {
            path: sidecar.clone(),
            reason: e.to_string(),
        })?;
        let map: serde_json::Map<String, serde_json::Value> = serde_json::from_str(&text)
            .map_err(|e| bad(&sidecar, format!("not a JSON object of metadata: {e}")))?;
        for (k, v) in map {
            if !super::contract::METADATA_KEYS.contains(&k.as_str()) {
                // Not an error (a newer exporter may add keys), but not silent either: a
                // misspelt key would otherwise leave its value unused without a word.
                eprintln!(
                    "groundscope: warning: {}: unknown key {} ignored (the contract's keys: {})",
                    sidecar.display(),
                    crate::env::error::shown(&k),
                    super::contract::METADATA_KEYS.join(", ")
                );
            }
            let v = match v {
                serde_json::Value::String(s) => s,
                other => other.to_string(),
            };
            props.insert(k, v);
        }
    }
    Ok(props)
}

/// Checks the inputs' names, types and static sizes; returns which form and which optional
/// inputs the graph takes.
pub(super) fn check_inputs(
    path: &Path,
    graph: &pb::GraphProto,
    memory_size: usize,
    reads: Reads,
) -> Result<Inputs, PolicyError> {
    let inputs = graph_inputs(graph);
    let find = |name: &str| inputs.iter().find(|v| v.name == name);
    let stray: Vec<String> = inputs
        .iter()
        .filter(|v| {
            !REQUIRED_INPUTS.contains(&v.name.as_str())
                && !STATE_INPUTS.contains(&v.name.as_str())
                && !OPTIONAL_INPUTS.contains(&v.name.as_str())
        })
        .map(|v| format!("\"{}\"", v.name))
        .collect();
    // A misnamed input shows up twice: as a stray name and as a contract input missing; one
    // line says both, with every name the contract knows.
    let contract = format!(
        "the contract's inputs: {}, and {} where the model reads them; optionally direction, and combined_override with override_weight; docs/onnx.md#inputs",
        REQUIRED_INPUTS.join(", "),
        STATE_INPUTS.join(" and ")
    );
    let stray_text = match stray.len() {
        0 => String::new(),
        1 => format!("; its input {} is not in the contract", stray[0]),
        _ => format!("; its inputs {} are not in the contract", stray.join(", ")),
    };
    for name in REQUIRED_INPUTS {
        if find(name).is_none() {
            return Err(bad(
                path,
                format!("the graph has no input \"{name}\"{stray_text} ({contract})"),
            ));
        }
    }
    if !stray.is_empty() {
        return Err(bad(
            path,
            format!("{} ({contract})", stray_text.trim_start_matches("; its ")),
        ));
    }
    warn_fixed_sizes(path, &inputs);
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
        reads,
    })
}

/// Warns about inputs that declare a fixed batch size (axis 0) or mission length (axis 1 of
/// `mission`): groundscope feeds any size, and tract runs such a graph as if the sizes were
/// dynamic, but onnxruntime and other runtimes refuse every other size: the export is likely
/// to be wrong elsewhere too (a reshape to the traced batch size, docs/onnx.md#dynamic-sizes).
fn warn_fixed_sizes(path: &Path, inputs: &[&pb::ValueInfoProto]) {
    let mut fixed = Vec::new();
    for v in inputs {
        let (_, Some(dims)) = declared(v) else {
            continue;
        };
        if let Some(Some(n)) = dims.first() {
            fixed.push(format!("{} batch {n}", v.name));
        }
        if v.name == "mission"
            && let Some(Some(n)) = dims.get(1)
        {
            fixed.push(format!("mission length {n}"));
        }
    }
    if !fixed.is_empty() {
        eprintln!(
            "groundscope: warning: {}: inputs declare fixed sizes ({}); groundscope runs any batch size and mission length, which onnxruntime would refuse: export them dynamic (docs/onnx.md#dynamic-sizes)",
            path.display(),
            fixed.join(", ")
        );
    }
}

/// Checks a declared shape's rank and static sizes, where the graph declares them.
pub(super) fn check_dims(
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

/// Checks the outputs; returns which optional ones are present and how many actions the
/// logits score ([`logits_width`]).
pub(super) fn check_outputs(
    path: &Path,
    graph: &pb::GraphProto,
    memory_size: usize,
    reads: Reads,
) -> Result<([bool; 3], usize), PolicyError> {
    let find = |name: &str| graph.output.iter().find(|v| v.name == name);
    let memory = reads.memory.then_some(MEMORY_OUTPUT);
    let mut actions = crate::env::Action::COUNT;
    for name in REQUIRED_OUTPUTS.into_iter().chain(memory) {
        let Some(v) = find(name) else {
            return Err(bad(
                path,
                format!(
                    "the graph has no output \"{name}\" (the contract's outputs: logits, value, and memory_out with memory)"
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
            "logits" => {
                check_dims(path, "output", name, dims.as_deref(), 2, &[])?;
                actions = logits_width(dims.as_deref()).map_err(|e| bad(path, e))?;
            }
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
    let optional = OPTIONAL_OUTPUTS.map(|name| find(name).is_some());
    if !reads.mission && (optional[0] || optional[1]) {
        return Err(bad(
            path,
            "the graph outputs word_maps or word_weights but takes no input \"mission\": a map per mission word needs the mission's words (docs/onnx.md#outputs)",
        ));
    }
    Ok((optional, actions))
}

/// Builds the optimised plan: inputs in the order image (, mission) (, memory) (, direction)
/// (, the override pair) — those the graph takes — with a symbolic batch `B` and mission
/// length `L`; outputs logits, value (, memory_out), then the optional ones present.
pub(super) fn build(
    path: &Path,
    onnx: &tract_onnx::Onnx,
    proto: &pb::ModelProto,
    given: Inputs,
    meta: &Meta,
    optional: [bool; 3],
) -> Result<Built, PolicyError> {
    let fail = |e: anyhow::Error| {
        let text = one_line(&e);
        bad(
            path,
            fixed_dimension(&text).unwrap_or(format!("tract: {text}")),
        )
    };
    let mut model = onnx.model_for_proto_model(proto).map_err(fail)?;
    let mut inputs = vec!["image"];
    if given.reads.mission {
        inputs.push("mission");
    }
    if given.reads.memory {
        inputs.push("memory");
    }
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
    let mut facts = vec![InferenceFact::dt_shape(
        image_type,
        [b.to_dim(), 7.to_dim(), 7.to_dim(), 3.to_dim()],
    )];
    if given.reads.mission {
        facts.push(InferenceFact::dt_shape(
            i64::datum_type(),
            [b.to_dim(), l.to_dim()],
        ));
    }
    if given.reads.memory {
        facts.push(InferenceFact::dt_shape(
            f32::datum_type(),
            [b.to_dim(), meta.memory_size.to_dim()],
        ));
    }
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
    if given.reads.memory {
        outputs.push(MEMORY_OUTPUT);
    }
    outputs.extend(
        OPTIONAL_OUTPUTS
            .iter()
            .zip(optional)
            .filter(|(_, on)| *on)
            .map(|(n, _)| *n),
    );
    model.select_outputs_by_name(&outputs).map_err(fail)?;
    let typed = model.into_typed().map_err(fail)?;
    // Before tract optimises (and runs constant parts of) the graph: the sizes as written.
    let bounds = Bounds::new(&typed, &b, &l);
    bounds.check(path, 1, 1)?;
    let typed = typed.into_decluttered().map_err(fail)?;
    let runnable = |m: TypedModel| m.into_optimized().and_then(IntoRunnable::into_runnable);
    // The mission (input 1) is cut off when it can be; a cut that tract cannot optimise
    // falls back to the whole graph, which is what every contract check above was made on.
    // A graph that reads no mission has nothing to cut.
    if given.reads.mission
        && let Ok(Some(parts)) = super::mission_cache::cut(&typed, 1, &b)
        && let (Ok(step), Ok(encoder)) = (runnable(parts.step), runnable(parts.encoder))
    {
        return Ok(Built {
            plan: step,
            missions: Some(MissionCache::new(encoder, parts.axes)),
            bounds,
        });
    }
    Ok(Built {
        plan: runnable(typed).map_err(fail)?,
        missions: None,
        bounds,
    })
}

/// What [`build`] makes of a graph.
pub(super) struct Built {
    /// The optimised plan (the step graph when the mission encoder was cut off).
    pub(super) plan: Arc<TypedRunnableModel>,
    /// The mission encoder cut from the graph, when it could be cut.
    pub(super) missions: Option<MissionCache>,
    /// The sizes of every tensor the graph computes.
    pub(super) bounds: Bounds,
}

/// A shape error of tract's that comes from a batch size or mission length fixed inside the
/// graph (a reshape to a constant shape, as a trace at one batch size leaves behind), said
/// as such: the node, the cause and what to do (docs/onnx.md#dynamic-sizes).
pub(super) fn fixed_dimension(tract: &str) -> Option<String> {
    let (what, axis) = if tract.contains("Sym(B)") {
        ("batch dimension", "axis 0 of every input and output")
    } else if tract.contains("Sym(L)") {
        (
            "mission length",
            "axis 1 of mission (and of word_maps, word_weights)",
        )
    } else {
        return None;
    };
    if !(tract.contains("unify") || tract.contains("mismatch")) {
        return None;
    }
    // tract names the node as `node #12 "name" Op`.
    let node = tract
        .split_once("for node #")
        .map_or_else(String::new, |(_, rest)| {
            let rest = rest.split_once(' ').map_or("", |(_, r)| r);
            let mut parts = rest.splitn(3, ' ');
            let name = parts.next().unwrap_or("");
            let op = parts.next().unwrap_or("").trim_end_matches(':');
            format!(" at node {name} ({op})")
        });
    Some(format!(
        "the {what} is fixed inside the graph{node}, but groundscope runs any size; export it \
         dynamic ({axis}: dynamic_axes in torch.onnx.export) and reshape with -1 or 0 for it, \
         not a number (docs/onnx.md#dynamic-sizes; tract: {tract})"
    ))
}
