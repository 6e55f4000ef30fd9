//! A Python callable as a groundscope policy: [`PyPolicy`] implements the core's `Acting`, so
//! the same episode runners, sweeps, metrics and recorders that run a checkpoint run it.
//!
//! The callable is `act(obs, first)`: `obs` a batch dict (`image` (N,7,7,3) uint8,
//! `direction` (N,) int64, `mission` a list of N str), `first` a bool array (N,) marking each
//! episode's first step. It returns logits (N,7), or (N,3) for a policy that scores only
//! MiniGrid's first three actions (left, right, forward: Dynamic-Obstacles' action space), or
//! a dict with `logits` and optionally `word_maps` (N,L,7,7), `word_weights` (N,L),
//! `combined_map` (N,7,7) and `values` (N,). The width is read from the first answer and held
//! at every later call; [`Acting::n_actions`] reports it (7 before the first call: the episode
//! runner reads it again after each step).
//!
//! The runners drop finished episodes from their batch; a Python policy keeps its own memory
//! by row, so the callable always sees the full batch, in a fixed order: row `i` is episode
//! `i` throughout. A finished episode's row repeats its last observation and its outputs are
//! ignored. Rows are recovered from the memory the runners carry: this adapter's "memory" is
//! each row's index, which the runners select along with the rows they keep.

use std::cell::RefCell;

use groundscope::env::Action;
use groundscope::env::view::Observation;
use groundscope::policy::onnx::{MapOutputs, trace};
use groundscope::policy::trace::ViewMap;
use groundscope::policy::{ActOutput, Acting, Memory, MissionInputs, PolicyError, Step, Variant};
use numpy::{PyArray1, PyArrayMethods as _};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::env::IMAGE_BYTES;

/// How the callable's maps index the view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapLayout {
    /// `[vx][vy]`, the axis order of `image` (what a channels-first conv gives).
    Image,
    /// `[vy][vx]`, row 0 farthest ahead: groundscope's own order.
    AgentUp,
}

impl MapLayout {
    /// `"image"` or `"agent-up"`.
    pub fn parse(s: &str) -> PyResult<Self> {
        match s {
            "image" => Ok(Self::Image),
            "agent-up" => Ok(Self::AgentUp),
            _ => Err(PyValueError::new_err(format!(
                "map_layout must be \"image\" or \"agent-up\", got {s:?}"
            ))),
        }
    }
}

/// The keys a callable's output dict may have.
const OUTPUT_KEYS: [&str; 5] = [
    "logits",
    "values",
    "word_maps",
    "word_weights",
    "combined_map",
];

/// The logits' widths a callable may return: MiniGrid's first 3 actions (left, right,
/// forward) or all 7.
const WIDTHS: [usize; 2] = [3, Action::COUNT];

/// How far a map's sum may stray from 1 (float32 softmaxes sum within 1e-6; a map normalised
/// in float16 within about 1e-3).
const MAP_SUM_TOLERANCE: f32 = 1e-2;

/// The batch the callable sees (full size, fixed rows).
#[derive(Default)]
struct Batch {
    missions: Vec<String>,
    image: Vec<u8>,
    direction: Vec<i64>,
    started: Vec<bool>,
    /// Whether the callable returned maps (`None` before its first answer).
    maps: Option<bool>,
    /// How many logits a row the callable returned, 3 or 7 (`None` before its first answer).
    width: Option<usize>,
    /// The Python exception that stopped the run, re-raised as it was.
    error: Option<PyErr>,
}

/// What one call returned for the active rows: logits, values and (with maps) the maps.
type Outputs = (Vec<Vec<f32>>, Vec<f32>, Option<Vec<MapOutputs>>);

/// A Python callable acting through the core's `Acting` interface.
pub struct PyPolicy<'py> {
    act: Bound<'py, PyAny>,
    layout: MapLayout,
    batch: RefCell<Batch>,
}

/// The memory of `rows` episodes of a Python policy: nothing (the policy keeps its own state,
/// per row of [`Step::rows`]).
fn memory_of_rows(rows: usize) -> Result<Memory, PolicyError> {
    groundscope::policy::acting::flat_memory_rows(Vec::new(), rows)
}

/// One float array out of a Python value (numpy array, list, or anything `np.asarray` takes,
/// such as a CPU torch tensor without grad), with its shape.
fn floats(value: &Bound<'_, PyAny>, what: &str) -> PyResult<(Vec<usize>, Vec<f32>)> {
    let arr = value
        .py()
        .import("numpy")?
        .call_method1("asarray", (value,))
        .and_then(|a| a.call_method1("astype", ("float32",)))
        .map_err(|e| PyValueError::new_err(format!("{what}: not an array of numbers ({e})")))?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let flat = arr.call_method0("ravel")?.cast_into::<PyArray1<f32>>()?;
    let data = flat.readonly().as_slice()?.to_vec();
    Ok((shape, data))
}

impl<'py> PyPolicy<'py> {
    /// The policy of `act`, whose maps are in `layout`.
    pub fn new(act: Bound<'py, PyAny>, layout: MapLayout) -> PyResult<Self> {
        if !act.is_callable() {
            return Err(PyValueError::new_err(
                "act must be callable as act(obs, first)",
            ));
        }
        Ok(Self {
            act,
            layout,
            batch: RefCell::new(Batch::default()),
        })
    }

    /// Starts a batch of episodes with these missions (row `i` is episode `i`).
    pub fn begin(&self, missions: Vec<String>) {
        let mut b = self.batch.borrow_mut();
        let n = missions.len();
        b.missions = missions;
        b.image = vec![0; n * IMAGE_BYTES];
        b.direction = vec![0; n];
        b.started = vec![false; n];
    }

    /// The exception the callable raised or its output caused, if the run stopped on one.
    pub fn take_error(&self) -> Option<PyErr> {
        self.batch.borrow_mut().error.take()
    }

    /// Whether the callable returned word maps (attention) or not (baseline).
    pub fn variant_seen(&self) -> Variant {
        Acting::variant(self)
    }

    fn fail(&self, e: PyErr) -> PolicyError {
        let msg = e.to_string();
        self.batch.borrow_mut().error = Some(e);
        PolicyError::Input(msg)
    }

    /// Calls the callable on the full batch; returns its output object.
    fn call(
        &self,
        rows: &[usize],
        obs: &[Observation],
        dirs: &[u8],
    ) -> PyResult<Bound<'py, PyAny>> {
        let py = self.act.py();
        let (image, direction, first, missions) = {
            let mut b = self.batch.borrow_mut();
            let n = b.missions.len();
            let mut first = vec![false; n];
            for (k, &r) in rows.iter().enumerate() {
                let dst = &mut b.image[r * IMAGE_BYTES..][..IMAGE_BYTES];
                for (d, s) in dst
                    .chunks_exact_mut(3)
                    .zip(obs[k].image.iter().flat_map(|c| c.iter()))
                {
                    d.copy_from_slice(s);
                }
                b.direction[r] = i64::from(dirs[k]);
                first[r] = !b.started[r];
                b.started[r] = true;
            }
            let image = PyArray1::from_slice(py, &b.image).reshape([n, 7, 7, 3])?;
            let direction = PyArray1::from_slice(py, &b.direction);
            let first = PyArray1::from_vec(py, first);
            (image, direction, first, PyList::new(py, &b.missions)?)
        };
        let obs = PyDict::new(py);
        obs.set_item("image", image)?;
        obs.set_item("direction", direction)?;
        obs.set_item("mission", missions)?;
        self.act.call1((obs, first))
    }

    /// Reads the callable's output for the active `rows` (with their mission tokens).
    fn read(
        &self,
        out: &Bound<'py, PyAny>,
        rows: &[usize],
        tokens: &[&[u32]],
    ) -> PyResult<Outputs> {
        let n = self.batch.borrow().missions.len();
        let dict = out.cast::<PyDict>().ok();
        if let Some(d) = &dict {
            // A misspelt key would otherwise drop its output in silence ('wordmaps': no maps).
            for key in d.keys() {
                let name: String = key.str()?.extract()?;
                if !OUTPUT_KEYS.contains(&name.as_str()) {
                    let close = OUTPUT_KEYS
                        .iter()
                        .min_by_key(|k| groundscope::env::babyai::registry::edit_distance(k, &name))
                        .copied()
                        .unwrap_or("logits");
                    return Err(PyValueError::new_err(format!(
                        "act returned an unknown key {name:?} (did you mean {close:?}? the keys are {})",
                        OUTPUT_KEYS.join(", ")
                    )));
                }
            }
        }
        let get = |key: &str| -> PyResult<Option<Bound<'py, PyAny>>> {
            match &dict {
                Some(d) => Ok(d.get_item(key)?.filter(|v| !v.is_none())),
                None => Ok(None),
            }
        };
        let logits_obj = match &dict {
            Some(_) => get("logits")?
                .ok_or_else(|| PyValueError::new_err("act returned a dict without 'logits'"))?,
            None => out.clone(),
        };
        let (shape, flat) = floats(&logits_obj, "logits")?;
        let width = match shape.as_slice() {
            [b, w] if *b == n && WIDTHS.contains(w) => *w,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "act returned logits of shape {shape:?}, expected (N, 3) or (N, 7) with N = {n} (MiniGrid's first 3 actions: left, right, forward; or all 7)"
                )));
            }
        };
        let seen = self.batch.borrow().width;
        if let Some(seen) = seen
            && seen != width
        {
            return Err(PyValueError::new_err(format!(
                "act returned {width} logits per row after {seen} on its first call: the width (3 or 7 actions) must stay the same at every call"
            )));
        }
        self.batch.borrow_mut().width = Some(width);
        let mut logits = Vec::with_capacity(rows.len());
        for &r in rows {
            let row = flat[r * width..][..width].to_vec();
            if row.iter().any(|x| !x.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "act returned non-finite logits[{r}]: {row:?}"
                )));
            }
            logits.push(row);
        }
        let values = match get("values")? {
            Some(v) => {
                let (shape, flat) = floats(&v, "values")?;
                if shape != [n] {
                    return Err(PyValueError::new_err(format!(
                        "act returned values of shape {shape:?}, expected ({n},)"
                    )));
                }
                rows.iter().map(|&r| flat[r]).collect()
            }
            None => vec![0.0; rows.len()],
        };
        let Some(maps_obj) = get("word_maps")? else {
            if get("word_weights")?.is_some() || get("combined_map")?.is_some() {
                return Err(PyValueError::new_err(
                    "act returned word_weights or combined_map without word_maps",
                ));
            }
            return Ok((logits, values, None));
        };
        let (shape, maps) = floats(&maps_obj, "word_maps")?;
        let l = match shape.as_slice() {
            [b, l, 7, 7] | [b, l, 49] if *b == n => *l,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "act returned word_maps of shape {shape:?}, expected ({n}, L, 7, 7)"
                )));
            }
        };
        let weights = get("word_weights")?
            .map(|w| -> PyResult<Vec<f32>> {
                let (shape, flat) = floats(&w, "word_weights")?;
                if shape != [n, l] {
                    return Err(PyValueError::new_err(format!(
                        "act returned word_weights of shape {shape:?}, expected ({n}, {l})"
                    )));
                }
                Ok(flat)
            })
            .transpose()?;
        let combined = get("combined_map")?
            .map(|c| -> PyResult<Vec<f32>> {
                let (shape, flat) = floats(&c, "combined_map")?;
                if shape != [n, 7, 7] && shape != [n, 49] {
                    return Err(PyValueError::new_err(format!(
                        "act returned combined_map of shape {shape:?}, expected ({n}, 7, 7)"
                    )));
                }
                Ok(flat)
            })
            .transpose()?;
        let mut out = Vec::with_capacity(rows.len());
        for (k, &r) in rows.iter().enumerate() {
            let words = tokens[k].len();
            if words > l {
                return Err(PyValueError::new_err(format!(
                    "act returned {l} word_maps per row; row {r}'s mission {:?} has {words} words",
                    self.batch.borrow().missions[r]
                )));
            }
            let map_at = |flat: &[f32], what: &str, w: usize| -> PyResult<ViewMap> {
                let cells = &flat[w * 49..][..49];
                if cells.iter().any(|x| !x.is_finite() || *x < 0.0) {
                    return Err(PyValueError::new_err(format!(
                        "act returned a negative or non-finite {what} in row {r}"
                    )));
                }
                // The metrics' thresholds (α / n) assume a distribution over the view: an
                // all-ones map would score every object as found.
                let sum: f32 = cells.iter().sum();
                if (sum - 1.0).abs() > MAP_SUM_TOLERANCE {
                    return Err(PyValueError::new_err(format!(
                        "act returned a {what} in row {r} that sums to {sum}: maps must be distributions over the 7×7 view (sum 1 ± {MAP_SUM_TOLERANCE}; a softmax over the 49 cells)"
                    )));
                }
                Ok(self.to_agent_up(cells))
            };
            let mission_words: Vec<&str> = tokens[k]
                .iter()
                .map(|&t| groundscope::env::vocab::word(t).unwrap_or("?"))
                .collect();
            let words_maps = (0..words)
                .map(|w| {
                    map_at(
                        &maps,
                        &format!("word_maps[{r}][{w}] (word {:?})", mission_words[w]),
                        r * l + w,
                    )
                })
                .collect::<PyResult<Vec<_>>>()?;
            let row_weights = weights
                .as_ref()
                .map(|f| f[r * l..][..words].to_vec())
                .filter(|w| w.iter().all(|x| x.is_finite() && *x >= 0.0));
            if weights.is_some() && row_weights.is_none() {
                return Err(PyValueError::new_err(format!(
                    "act returned a negative or non-finite word_weights in row {r}"
                )));
            }
            let row_combined = combined
                .as_ref()
                .map(|f| map_at(f, "combined_map", r))
                .transpose()?;
            out.push(MapOutputs {
                words: Some(words_maps),
                weights: row_weights,
                combined: row_combined,
            });
        }
        Ok((logits, values, Some(out)))
    }

    fn to_agent_up(&self, cells: &[f32]) -> ViewMap {
        let mut m = [[0.0; 7]; 7];
        for (j, &x) in cells.iter().enumerate() {
            match self.layout {
                // flat vx·7 + vy → m[vy][vx]
                MapLayout::Image => m[j % 7][j / 7] = x,
                MapLayout::AgentUp => m[j / 7][j % 7] = x,
            }
        }
        m
    }

    fn step(
        &self,
        obs: &[Observation],
        dirs: &[u8],
        tokens: &[&[u32]],
        rows: &[usize],
        memory: &Memory,
    ) -> PyResult<ActOutput> {
        let out = self.call(rows, obs, dirs)?;
        let (logits, values, maps) = self.read(&out, rows, tokens)?;
        {
            let mut b = self.batch.borrow_mut();
            let has = maps.is_some();
            if b.maps.is_some_and(|m| m != has) {
                return Err(PyValueError::new_err(
                    "act returned word_maps on some steps and not on others",
                ));
            }
            b.maps = Some(has);
        }
        let traces = maps
            .map(|maps| {
                tokens
                    .iter()
                    .zip(&maps)
                    .map(|(t, m)| trace(t, m))
                    .collect::<Result<Vec<_>, _>>()
            })
            .transpose()
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(ActOutput {
            probs: logits
                .iter()
                .map(|l| groundscope::policy::acting::softmax(l))
                .collect(),
            logits,
            values,
            memory: memory.clone(),
            traces,
        })
    }
}

impl Acting for PyPolicy<'_> {
    fn variant(&self) -> Variant {
        if self.batch.borrow().maps == Some(true) {
            Variant::Attention
        } else {
            Variant::Baseline
        }
    }

    fn zero_memory(&self) -> Result<Memory, PolicyError> {
        memory_of_rows(1)
    }

    fn prepare(&self, _tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError> {
        Ok(None)
    }

    fn act_step(&self, step: &Step<'_>) -> Result<ActOutput, PolicyError> {
        self.step(
            step.obs,
            step.directions,
            step.missions,
            step.rows,
            step.memory,
        )
        .map_err(|e| self.fail(e))
    }

    fn zero_memory_batch(&self, batch: usize) -> Result<Memory, PolicyError> {
        memory_of_rows(batch)
    }

    fn prepare_batch(&self, _missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError> {
        Ok(None)
    }

    fn takes_interventions(&self) -> bool {
        false
    }

    /// The width of the callable's logits, 3 or 7, as its first answer gave it (7 before).
    fn n_actions(&self) -> usize {
        self.batch.borrow().width.unwrap_or(Action::COUNT)
    }
}
