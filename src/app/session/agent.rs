//! A loaded policy, shared by the session and the jobs that run it.

use std::sync::Arc;

use crate::env::level::LevelConfig;
use crate::policy::Acting;

/// A loaded policy, ready to act: a native checkpoint or an imported ONNX graph.
#[derive(Clone, Debug)]
pub struct Agent {
    /// What the user chose: `bundled:attention`, `bundled:baseline`, a checkpoint path or a
    /// `.onnx` file.
    pub spec: String,
    /// The policy, shared with the jobs that run it.
    pub policy: Arc<crate::policy::Agent>,
}

impl Agent {
    /// Loads `spec` ([`crate::policy::Agent::load`]).
    pub fn load(spec: &str) -> Result<Self, String> {
        let policy = crate::policy::Agent::load(spec).map_err(|e| e.to_string())?;
        Ok(Self {
            spec: spec.to_owned(),
            policy: Arc::new(policy),
        })
    }

    /// The level it was trained on.
    pub fn level(&self) -> LevelConfig {
        self.policy.level()
    }

    /// The policy, to run episodes with.
    pub fn acting(&self) -> &(dyn Acting + Send + Sync) {
        self.policy.acting()
    }
}
