//! Checkpoints: `NAME.safetensors` (weights) + `NAME.json` (what the weights are).
//!
//! Loading checks the JSON, the vocabulary, the SHA-256 of the weights file, and every tensor
//! name, dtype and shape, and names the first thing that is wrong.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use candle_core::{Device, Tensor};
use serde::{Deserialize, Serialize};
use sha2::{Digest as _, Sha256};

use super::config::ModelConfig;
use super::error::PolicyError;
use super::params::{Params, param_specs};
use crate::env::level::LevelConfig;
use crate::env::vocab::VOCABULARY;

/// The `format` value of every checkpoint JSON.
pub const FORMAT: &str = "groundscope-checkpoint";
/// The current checkpoint format version.
pub const FORMAT_VERSION: u32 = 1;

/// Metrics of the last training update, as saved with a checkpoint.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainingState {
    /// Environment frames trained on.
    pub frames: u64,
    /// PPO updates done.
    pub updates: u64,
    /// Success rate of the episodes finished in the last logging window.
    pub success_rate: Option<f64>,
    /// Mean reward of those episodes.
    pub mean_reward: Option<f64>,
    /// Seed of the run (or of the initialisation).
    pub seed: u64,
}

/// `NAME.json`: everything about the weights except the weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointMeta {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`FORMAT_VERSION`].
    pub format_version: u32,
    /// The network sizes and variant.
    pub model: ModelConfig,
    /// Token id → word (id 0 is padding).
    pub vocabulary: Vec<String>,
    /// The level the weights were trained on.
    pub level: LevelConfig,
    /// Training progress.
    pub training: TrainingState,
    /// groundscope version that wrote the file.
    pub crate_version: String,
    /// SHA-256 of `NAME.safetensors`, hex.
    pub weights_sha256: String,
}

/// A loaded checkpoint.
#[derive(Clone, Debug)]
pub struct Checkpoint {
    /// Metadata.
    pub meta: CheckpointMeta,
    /// Weights.
    pub params: Params,
}

/// The two file paths of a checkpoint named `name` (`x`, `x.json` or `x.safetensors`).
pub fn checkpoint_paths(name: &Path) -> (PathBuf, PathBuf) {
    let base = match name.extension().and_then(|e| e.to_str()) {
        Some("json" | "safetensors") => name.with_extension(""),
        _ => name.to_path_buf(),
    };
    let add = |ext: &str| {
        let mut s = base.clone().into_os_string();
        s.push(ext);
        PathBuf::from(s)
    };
    (add(".safetensors"), add(".json"))
}

fn sha256_hex(bytes: &[u8]) -> String {
    use std::fmt::Write as _;
    Sha256::digest(bytes)
        .iter()
        .fold(String::with_capacity(64), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        })
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> PolicyError {
    PolicyError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// Writes `bytes` to `path` via a temporary file in the same directory and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), PolicyError> {
    use std::io::Write as _;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(|e| io_err(path, e))?;
    tmp.write_all(bytes).map_err(|e| io_err(path, e))?;
    crate::files::make_shareable(tmp.path()).map_err(|e| io_err(path, e))?;
    tmp.persist(path).map_err(|e| io_err(path, e.error))?;
    Ok(())
}

/// The safetensors bytes of `params` (tensors sorted by name; deterministic).
pub fn weights_bytes(params: &Params) -> Result<Vec<u8>, PolicyError> {
    let mut data: Vec<(String, Vec<usize>, Vec<u8>)> = Vec::new();
    for (name, var) in &params.vars {
        let t = var.as_tensor();
        let v = t.flatten_all()?.to_vec1::<f32>()?;
        let bytes = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        data.push((name.clone(), t.dims().to_vec(), bytes));
    }
    let views: Vec<(String, safetensors::tensor::TensorView<'_>)> = data
        .iter()
        .map(|(n, shape, b)| {
            safetensors::tensor::TensorView::new(safetensors::Dtype::F32, shape.clone(), b)
                .map(|v| (n.clone(), v))
        })
        .collect::<Result<_, _>>()
        .map_err(|e| PolicyError::Input(format!("building safetensors view: {e}")))?;
    safetensors::serialize(views, None)
        .map_err(|e| PolicyError::Input(format!("serialising safetensors: {e}")))
}

impl Checkpoint {
    /// A checkpoint of `params`; the hash is filled in by [`Checkpoint::save`].
    pub fn new(
        model: ModelConfig,
        level: LevelConfig,
        training: TrainingState,
        params: Params,
    ) -> Self {
        Self {
            meta: CheckpointMeta {
                format: FORMAT.into(),
                format_version: FORMAT_VERSION,
                model,
                vocabulary: VOCABULARY.iter().map(|w| (*w).to_owned()).collect(),
                level,
                training,
                crate_version: env!("CARGO_PKG_VERSION").into(),
                weights_sha256: String::new(),
            },
            params,
        }
    }

    /// Writes `NAME.safetensors` then `NAME.json`, each atomically.
    pub fn save(&mut self, name: &Path) -> Result<(), PolicyError> {
        let (st, js) = checkpoint_paths(name);
        let bytes = weights_bytes(&self.params)?;
        self.meta.weights_sha256 = sha256_hex(&bytes);
        let json = serde_json::to_string_pretty(&self.meta)
            .map_err(|e| PolicyError::Input(format!("serialising checkpoint metadata: {e}")))?;
        write_atomic(&st, &bytes)?;
        write_atomic(&js, json.as_bytes())?;
        Ok(())
    }

    /// Loads and checks a checkpoint.
    pub fn load(name: &Path) -> Result<Self, PolicyError> {
        let (st, js) = checkpoint_paths(name);
        let text = std::fs::read_to_string(&js).map_err(|e| io_err(&js, e))?;
        let bytes = std::fs::read(&st).map_err(|e| io_err(&st, e))?;
        Self::from_parts(&text, &bytes, &js, &st)
    }

    /// Checks and builds a checkpoint from the JSON text and the safetensors bytes; the paths
    /// only label errors.
    pub fn from_parts(text: &str, bytes: &[u8], js: &Path, st: &Path) -> Result<Self, PolicyError> {
        let bad = |path: &Path, field: &str, reason: String| PolicyError::Checkpoint {
            path: path.to_path_buf(),
            field: field.to_owned(),
            reason,
        };
        let meta: CheckpointMeta = serde_json::from_str(text).map_err(|e| {
            bad(
                js,
                &format!("line {} column {}", e.line(), e.column()),
                e.to_string(),
            )
        })?;
        if meta.format != FORMAT {
            return Err(bad(
                js,
                "format",
                format!("{:?} is not {FORMAT:?}", meta.format),
            ));
        }
        if meta.format_version != FORMAT_VERSION {
            return Err(bad(
                js,
                "format_version",
                format!(
                    "{} is not supported (this build reads {FORMAT_VERSION})",
                    meta.format_version
                ),
            ));
        }
        if meta.vocabulary.len() != VOCABULARY.len()
            || meta.vocabulary.iter().zip(VOCABULARY).any(|(a, b)| a != b)
        {
            let first = meta
                .vocabulary
                .iter()
                .zip(VOCABULARY)
                .position(|(a, b)| a != b)
                .unwrap_or(meta.vocabulary.len().min(VOCABULARY.len()));
            return Err(bad(
                js,
                "vocabulary",
                format!(
                    "differs from this build's at id {first} ({:?} vs {:?}); the checkpoint cannot read these missions",
                    meta.vocabulary.get(first),
                    VOCABULARY.get(first)
                ),
            ));
        }
        meta.level
            .validate()
            .map_err(|e| bad(js, "level", e.to_string()))?;
        let hash = sha256_hex(bytes);
        if hash != meta.weights_sha256 {
            return Err(bad(
                st,
                "weights_sha256",
                format!(
                    "file hash {hash} differs from {} recorded in {}",
                    meta.weights_sha256,
                    js.display()
                ),
            ));
        }
        let tensors = safetensors::SafeTensors::deserialize(bytes)
            .map_err(|e| bad(st, "safetensors", e.to_string()))?;
        let mut map = BTreeMap::new();
        let specs = param_specs(&meta.model);
        for s in &specs {
            let view = tensors
                .tensor(&s.name)
                .map_err(|_| bad(st, &s.name, "tensor is missing".into()))?;
            if view.dtype() != safetensors::Dtype::F32 {
                return Err(bad(
                    st,
                    &s.name,
                    format!("dtype {:?} is not F32", view.dtype()),
                ));
            }
            if view.shape() != s.shape.as_slice() {
                return Err(bad(
                    st,
                    &s.name,
                    format!("shape {:?} is not {:?}", view.shape(), s.shape),
                ));
            }
            let data: Vec<f32> = view
                .data()
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            if data.iter().any(|x| !x.is_finite()) {
                return Err(bad(st, &s.name, "holds NaN or infinite values".into()));
            }
            map.insert(
                s.name.clone(),
                Tensor::from_vec(data, s.shape.as_slice(), &Device::Cpu)?,
            );
        }
        if let Some(extra) = tensors.names().into_iter().find(|n| !map.contains_key(*n)) {
            return Err(bad(
                st,
                extra,
                format!(
                    "unexpected tensor for a {} model",
                    meta.model.variant.name()
                ),
            ));
        }
        Ok(Self {
            meta,
            params: Params::from_tensors(map)?,
        })
    }
}
