//! The memory bound of an imported graph: no tensor it computes may be larger than
//! [`TENSOR_BYTES_MAX`] (docs/onnx.md#limits).
//!
//! A graph is a program: a valid one can ask for `ConstantOfShape [200000, 200000]` (160 GB)
//! or expand its memory to (B, 8, 10⁹). tract allocates what it is asked for; a failed
//! allocation panics, and one that the kernel grants is filled until the process is killed
//! for memory. So the sizes are checked before anything that large exists, in two places:
//!
//! - in the file, before tract reads it: a `ConstantOfShape` or `Expand` whose target shape
//!   is a constant (tract folds such constants while it infers the graph's shapes, so that
//!   is the last moment they can be refused);
//! - in the shapes tract infers, where they depend on the batch size B and the mission
//!   length L: every node output of the typed graph is evaluated at B = L = 1 when the file
//!   is loaded, and again for each (B, L) a step is about to run with.

use std::collections::HashSet;
use std::path::Path;
use std::sync::Mutex;

use tract_onnx::pb;
use tract_onnx::prelude::*;

use super::load::bad;
use crate::policy::error::PolicyError;

/// The largest tensor an imported graph may compute, in bytes (1 GiB). The bundled model's
/// export computes at most a few MB a row at the largest batches groundscope runs.
pub const TENSOR_BYTES_MAX: u64 = 1 << 30;

/// Shown after a refusal: what the bound is and where it is documented.
const WHY: &str = "groundscope refuses any tensor over 1 GiB (docs/onnx.md#limits)";

fn shown(dims: &[String]) -> String {
    format!("({})", dims.join(", "))
}

/// The values of the int64 constants of `graph` (initializers and `Constant` nodes), by name.
fn int_constants(graph: &pb::GraphProto) -> std::collections::HashMap<&str, Vec<i64>> {
    let values = |t: &pb::TensorProto| -> Option<Vec<i64>> {
        // The values are either in int64_data or little-endian raw bytes.
        (t.data_type == super::contract::ONNX_INT64).then(|| {
            if t.raw_data.is_empty() {
                t.int64_data.clone()
            } else {
                t.raw_data
                    .chunks_exact(8)
                    .map(|b| i64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
                    .collect()
            }
        })
    };
    let mut out: std::collections::HashMap<&str, Vec<i64>> = graph
        .initializer
        .iter()
        .filter_map(|t| Some((t.name.as_str(), values(t)?)))
        .collect();
    for node in graph.node.iter().filter(|n| n.op_type == "Constant") {
        if let (Some(name), Some(v)) = (
            node.output.first(),
            node.attribute
                .iter()
                .find(|a| a.name == "value")
                .and_then(|a| a.t.as_ref())
                .and_then(values),
        ) {
            out.insert(name.as_str(), v);
        }
    }
    out
}

/// Refuses a `ConstantOfShape` or `Expand` of `graph` (and its subgraphs) whose constant
/// target shape holds more than [`TENSOR_BYTES_MAX`] (at 4 bytes an element for an `Expand`,
/// whose element type is not read here; the output of an `Expand` is at least its shape).
pub(super) fn check_constant_shapes(
    path: &Path,
    graph: &pb::GraphProto,
) -> Result<(), PolicyError> {
    let constants = int_constants(graph);
    for node in &graph.node {
        for a in &node.attribute {
            for g in a.g.iter().chain(&a.graphs) {
                check_constant_shapes(path, g)?;
            }
        }
        let shape_input = match node.op_type.as_str() {
            "ConstantOfShape" => node.input.first(),
            "Expand" => node.input.get(1),
            _ => None,
        };
        let Some(shape) = shape_input.and_then(|i| constants.get(i.as_str())) else {
            continue;
        };
        let elem: u64 = if node.op_type == "ConstantOfShape" {
            node.attribute
                .iter()
                .find(|a| a.name == "value")
                .and_then(|a| a.t.as_ref())
                .map_or(4, |t| element_bytes(t.data_type))
        } else {
            4
        };
        let bytes = shape.iter().try_fold(elem, |acc, &d| {
            acc.checked_mul(u64::try_from(d.max(0)).ok()?)
        });
        if bytes.is_none_or(|b| b > TENSOR_BYTES_MAX) {
            let dims: Vec<String> = shape.iter().map(ToString::to_string).collect();
            return Err(bad(
                path,
                format!(
                    "node {} ({}) makes a tensor of shape {} ({}); {WHY}",
                    node_name(node),
                    node.op_type,
                    shown(&dims),
                    size(bytes)
                ),
            ));
        }
    }
    Ok(())
}

fn node_name(node: &pb::NodeProto) -> String {
    if node.name.is_empty() {
        format!("\"{}\"", node.output.first().map_or("?", String::as_str))
    } else {
        format!("\"{}\"", node.name)
    }
}

/// Bytes an element of an ONNX data type takes (4 where unsure).
fn element_bytes(data_type: i32) -> u64 {
    match data_type {
        2 | 3 | 9 => 1,   // uint8, int8, bool
        4 | 5 | 10 => 2,  // uint16, int16, float16
        7 | 11 | 13 => 8, // int64, double, uint64
        _ => 4,
    }
}

fn size(bytes: Option<u64>) -> String {
    match bytes {
        Some(b) if b >= 1 << 30 => format!("{:.1} GiB", b as f64 / f64::from(1u32 << 30)),
        Some(b) => format!("{b} bytes"),
        None => "more bytes than a 64-bit count holds".into(),
    }
}

/// Every node output of a typed graph, its shape in B and L, and its element size: checked
/// for each (B, L) before a step runs with them.
pub(super) struct Bounds {
    tensors: Vec<(String, TVec<TDim>, u64)>,
    batch: Symbol,
    length: Symbol,
    checked: Mutex<HashSet<(usize, usize)>>,
}

impl Bounds {
    /// The outputs of every node of `model`, whose batch size is the symbol `batch` and
    /// mission length `length`.
    pub(super) fn new(model: &TypedModel, batch: &Symbol, length: &Symbol) -> Self {
        let mut tensors = Vec::new();
        for node in &model.nodes {
            for o in &node.outputs {
                let elem = o.fact.datum_type.size_of() as u64;
                tensors.push((node.name.clone(), o.fact.shape.to_tvec(), elem));
            }
        }
        Self {
            tensors,
            batch: batch.clone(),
            length: length.clone(),
            checked: Mutex::new(HashSet::new()),
        }
    }

    /// Refuses the graph when a tensor it would compute for a batch of `b` missions of `l`
    /// words is over [`TENSOR_BYTES_MAX`], naming the node and its shape. A dimension
    /// tract could not express in B and L (one that depends on the values computed) is not
    /// known before the run, and not counted.
    pub(super) fn check(&self, path: &Path, b: usize, l: usize) -> Result<(), PolicyError> {
        if self.checked.lock().is_ok_and(|c| c.contains(&(b, l))) {
            return Ok(());
        }
        let values = SymbolValues::default()
            .with(&self.batch, b as i64)
            .with(&self.length, l as i64);
        for (name, shape, elem) in &self.tensors {
            let dims: Vec<Option<i64>> = shape
                .iter()
                .map(|d| d.eval(&values).to_i64().ok())
                .collect();
            if dims.iter().any(Option::is_none) {
                continue;
            }
            let bytes = dims.iter().flatten().try_fold(*elem, |acc, &d| {
                acc.checked_mul(u64::try_from(d.max(0)).ok()?)
            });
            if bytes.is_none_or(|x| x > TENSOR_BYTES_MAX) {
                let symbolic: Vec<String> = shape.iter().map(ToString::to_string).collect();
                return Err(bad(
                    path,
                    format!(
                        "node \"{name}\" computes a tensor of shape {} ({} at B = {b}, L = {l}); {WHY}",
                        shown(&symbolic),
                        size(bytes)
                    ),
                ));
            }
        }
        if let Ok(mut c) = self.checked.lock() {
            c.insert((b, l));
        }
        Ok(())
    }
}
