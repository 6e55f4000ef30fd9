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
    /// The weight λ of `train --ground-loss` if the maps were supervised, by this run or by a
    /// run it was started from with `--init`; absent for maps trained from the policy's loss
    /// alone, as the paper's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground_loss: Option<f64>,
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

/// The checkpoint a name given to a reader stands for: a run directory names the model the run
/// keeps in it (`RUN` → `RUN/model`); any other name stands for itself.
pub fn checkpoint_name(name: &Path) -> std::borrow::Cow<'_, Path> {
    if name.is_dir() {
        std::borrow::Cow::Owned(name.join("model"))
    } else {
        std::borrow::Cow::Borrowed(name)
    }
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

/// Writes `bytes` to `path` atomically and durably (see [`crate::files`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), PolicyError> {
    crate::files::write_output(path, bytes).map_err(|e| io_err(path, e))
}

/// The name of the copy of the previous weights kept while a checkpoint is being replaced.
fn prev_weights_path(st: &Path) -> PathBuf {
    let mut s = st.as_os_str().to_owned();
    s.push(".prev");
    PathBuf::from(s)
}

/// What identifies one version of a file: its inode and modification time.
fn file_stamp(path: &Path) -> Option<(u64, std::time::SystemTime)> {
    let meta = std::fs::metadata(path).ok()?;
    #[cfg(unix)]
    let ino = std::os::unix::fs::MetadataExt::ino(&meta);
    #[cfg(not(unix))]
    let ino = meta.len();
    Some((ino, meta.modified().ok()?))
}

fn is_hash_mismatch(err: &PolicyError) -> bool {
    matches!(err, PolicyError::Checkpoint { field, .. } if field == "weights_sha256")
}

/// How often and how long [`Checkpoint::load`] re-reads a pair caught in the middle of being
/// replaced by another process (about two seconds in all).
const LOAD_TRIES: u32 = 40;
const LOAD_RETRY_PAUSE: std::time::Duration = std::time::Duration::from_millis(50);

/// Writes the two files of a checkpoint so that a reader or a crash at any instant sees the old
/// checkpoint or the new one, complete. The JSON is the commit point: both new files are
/// written and flushed under temporary names first; the old weights are kept as
/// `NAME.safetensors.prev` (a hard link) while the new weights are renamed into place and the
/// JSON after them; then the copy is removed. Between the two renames the JSON still names the
/// old weights, which [`Checkpoint::load`] finds in the `.prev` copy. On an error before the
/// switch the old checkpoint is untouched; if the JSON cannot be renamed, the old weights are
/// put back.
fn save_pair(st: &Path, js: &Path, weights: &[u8], json: &[u8]) -> Result<(), PolicyError> {
    for p in [st, js] {
        if std::fs::symlink_metadata(p).is_ok_and(|m| !m.is_file()) {
            return Err(io_err(p, "is not a regular file; refusing to replace it"));
        }
    }
    let dir = crate::files::parent_dir(st);
    let tmp_w = crate::files::staged(dir, weights).map_err(|e| io_err(st, e))?;
    let tmp_j = crate::files::staged(dir, json).map_err(|e| io_err(js, e))?;
    let prev = prev_weights_path(st);
    let had_old = st.exists();
    if had_old {
        let _ = std::fs::remove_file(&prev);
        std::fs::hard_link(st, &prev).map_err(|e| io_err(&prev, e))?;
        crate::files::sync_dir(dir).map_err(|e| io_err(dir, e))?;
    }
    tmp_w.persist(st).map_err(|e| io_err(st, e.error))?;
    if let Err(e) = tmp_j.persist(js) {
        if had_old {
            let _ = std::fs::rename(&prev, st);
        }
        return Err(io_err(js, e.error));
    }
    crate::files::sync_dir(dir).map_err(|e| io_err(dir, e))?;
    if had_old {
        let _ = std::fs::remove_file(&prev);
    }
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
                vocabulary: VOCABULARY[..model.vocab_size.min(VOCABULARY.len())]
                    .iter()
                    .map(|w| (*w).to_owned())
                    .collect(),
                level,
                training,
                crate_version: env!("CARGO_PKG_VERSION").into(),
                weights_sha256: String::new(),
            },
            params,
        }
    }

    /// Writes `NAME.safetensors` and `NAME.json` as one atomic unit (see `save_pair`).
    pub fn save(&mut self, name: &Path) -> Result<(), PolicyError> {
        let (st, js) = checkpoint_paths(name);
        let text = name.to_string_lossy();
        if matches!(text.rsplit('/').next(), None | Some("" | "." | "..")) {
            return Err(io_err(
                name,
                "is not a checkpoint name (give a file name, e.g. runs/model)",
            ));
        }
        let bytes = weights_bytes(&self.params)?;
        self.meta.weights_sha256 = sha256_hex(&bytes);
        let json = serde_json::to_string_pretty(&self.meta)
            .map_err(|e| PolicyError::Input(format!("serialising checkpoint metadata: {e}")))?;
        save_pair(&st, &js, &bytes, json.as_bytes())
    }

    /// Loads and checks a checkpoint. A pair caught between its two renames by
    /// [`Checkpoint::save`] in another process (the JSON still naming the previous weights) is
    /// read from the kept previous weights or read again, so a reader never fails on a
    /// checkpoint being rewritten. A directory names the checkpoint a training run keeps in
    /// it (`RUN` → `RUN/model`).
    pub fn load(name: &Path) -> Result<Self, PolicyError> {
        let (st, js) = checkpoint_paths(&checkpoint_name(name));
        let mut tries = 0;
        loop {
            let before = (file_stamp(&js), file_stamp(&st));
            let text = crate::files::read_regular_to_string(&js).map_err(|e| io_err(&js, e))?;
            let bytes = crate::files::read_regular(&st).map_err(|e| io_err(&st, e))?;
            match Self::from_parts(&text, &bytes, &js, &st) {
                Err(err @ PolicyError::Checkpoint { .. }) if is_hash_mismatch(&err) => {
                    let prev = prev_weights_path(&st);
                    if let Ok(old) = crate::files::read_regular(&prev)
                        && let Ok(ckpt) = Self::from_parts(&text, &old, &js, &st)
                    {
                        return Ok(ckpt);
                    }
                    // Only a pair that changed while it was read is read again; a pair that
                    // stands still is reported at once.
                    let moving = prev.exists() || before != (file_stamp(&js), file_stamp(&st));
                    if !moving || tries >= LOAD_TRIES {
                        return Err(err);
                    }
                    tries += 1;
                    std::thread::sleep(LOAD_RETRY_PAUSE);
                }
                other => return other,
            }
        }
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
        // The model's rows are the first `vocab_size` words of this build's vocabulary.
        let ours = &VOCABULARY[..meta.model.vocab_size.min(VOCABULARY.len())];
        if meta.vocabulary.len() != ours.len()
            || meta.vocabulary.iter().zip(ours).any(|(a, b)| a != b)
        {
            let first = meta
                .vocabulary
                .iter()
                .zip(ours)
                .position(|(a, b)| a != b)
                .unwrap_or(meta.vocabulary.len().min(ours.len()));
            return Err(bad(
                js,
                "vocabulary",
                format!(
                    "differs from this build's at id {first} ({:?} vs {:?}); the checkpoint cannot read these missions",
                    meta.vocabulary.get(first),
                    ours.get(first)
                ),
            ));
        }
        meta.level
            .validate()
            .map_err(|e| bad(js, "level", e.to_string()))?;
        meta.model
            .validate()
            .map_err(|e| bad(js, "model", e.to_string()))?;
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
