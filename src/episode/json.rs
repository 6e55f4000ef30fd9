//! The JSON form of a trace (documented in docs/formats.md#episode-traces).

use std::path::Path;

use serde::Serialize;

use super::{ActionMode, EpisodeTrace, StepFaithfulness};
use crate::env::level::LevelConfig;
use crate::env::snapshot::Snapshot;
use crate::policy::{self, AttentionTrace, PolicyError};

/// JSON form of one step (documented in docs/formats.md#episode-traces).
#[derive(Serialize)]
struct StepJson<'a> {
    t: usize,
    agent_pos: [i32; 2],
    agent_dir: u8,
    carrying: Option<[u8; 3]>,
    obs: Vec<Vec<Vec<u8>>>,
    action: u8,
    action_name: &'static str,
    probs: &'a [f32],
    value: f32,
    reward: f64,
    terminated: bool,
    truncated: bool,
    attention: Option<&'a AttentionTrace>,
    expert_action: Option<u8>,
    expert_plan: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    faithfulness: Option<&'a StepFaithfulness>,
}

/// JSON form of a trace (documented in docs/formats.md#episode-traces).
#[derive(Serialize)]
struct TraceJson<'a> {
    schema_version: u32,
    checkpoint: &'a str,
    variant: &'static str,
    level: &'a LevelConfig,
    seed: u64,
    mission: &'a str,
    tokens: Vec<&'static str>,
    token_ids: &'a [u32],
    #[serde(skip_serializing_if = "Option::is_none")]
    graph_token_ids: Option<&'a [i64]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    model_name: Option<&'a str>,
    mode: ActionMode,
    success: bool,
    total_reward: f64,
    initial_state: Snapshot,
    steps: Vec<StepJson<'a>>,
}

impl EpisodeTrace {
    /// The trace as pretty JSON.
    pub fn to_json(&self) -> String {
        let first = self.steps.first().map_or(&self.final_world, |s| &s.world);
        let json = TraceJson {
            schema_version: 1,
            checkpoint: &self.checkpoint,
            variant: self.variant.name(),
            level: &self.level,
            seed: self.seed,
            mission: &self.mission,
            tokens: self.words(),
            token_ids: &self.tokens,
            graph_token_ids: self.input_token_ids.as_deref(),
            model_name: self.model_name.as_deref(),
            mode: self.mode,
            success: self.success(),
            total_reward: self.total_reward(),
            initial_state: Snapshot::from_world(
                first,
                Some(self.level.to_string()),
                Some(self.seed),
            ),
            steps: self
                .steps
                .iter()
                .map(|s| StepJson {
                    t: s.t,
                    agent_pos: [s.world.agent_pos.0, s.world.agent_pos.1],
                    agent_dir: s.world.agent_dir,
                    carrying: s.world.carrying.map(|c| c.encode()),
                    obs: s.obs.to_nested(),
                    action: s.action as u8,
                    action_name: s.action.name(),
                    probs: self.action_probs(s),
                    value: s.value,
                    reward: s.reward,
                    terminated: s.terminated,
                    truncated: s.truncated,
                    attention: s.attention.as_ref(),
                    expert_action: s.expert_action.map(|a| a as u8),
                    expert_plan: &s.expert_plan,
                    faithfulness: s.faithfulness.as_ref(),
                })
                .collect(),
        };
        // Plain data with string keys and finite floats cannot fail to serialise.
        serde_json::to_string_pretty(&json).unwrap_or_default()
    }

    /// Writes the JSON trace atomically.
    pub fn save_json(&self, path: &Path) -> Result<(), PolicyError> {
        policy::checkpoint::write_atomic(path, self.to_json().as_bytes())
    }
}
