//! Snapshots of MiniGrid's own environments: regenerated from their id and seed, since their
//! step rules live in no dump field.

use super::{Snapshot, invalid};
use crate::env::error::EnvError;
use crate::env::world::World;

impl Snapshot {
    /// A MiniGrid environment's snapshot (`instr` null): regenerated from `env_id` and
    /// `seed`, which must give the snapshot's grid and pose (a reset; its step rules live in
    /// no dump field).
    pub(super) fn minigrid_world(&self) -> Result<World, EnvError> {
        let id = self.env_id.as_deref().ok_or_else(|| {
            invalid(
                "instr",
                "null needs env_id and seed: a MiniGrid dump is regenerated from them",
            )
        })?;
        let level = crate::env::LevelId::parse(id).map_err(|e| match e {
            EnvError::InvalidConfig { reason, .. } => invalid("env_id", reason),
            e => e,
        })?;
        if level.minigrid().is_none() {
            return Err(invalid(
                "instr",
                format!("null: {id} is a BabyAI level, whose dumps carry their instruction"),
            ));
        }
        let seed = self
            .seed
            .ok_or_else(|| invalid("seed", "a MiniGrid dump needs its seed to be regenerated"))?;
        if self.step_count != 0 {
            return Err(invalid(
                "step_count",
                "a MiniGrid dump is regenerated at reset: only step_count 0 can be read",
            ));
        }
        let world = crate::env::LevelConfig::babyai(level, false).generate(seed)?;
        let fresh = Self::from_world(&world, self.env_id.clone(), Some(seed));
        if fresh.grid != self.grid
            || fresh.agent_pos != self.agent_pos
            || fresh.agent_dir != self.agent_dir
        {
            return Err(invalid(
                "grid",
                format!("{id} seed {seed} generates another grid or pose than this dump holds"),
            ));
        }
        Ok(world)
    }
}
