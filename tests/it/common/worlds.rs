//! Levels and first views shared by the model tests.

use groundscope::env::view::Observation;
use groundscope::env::{LevelConfig, LevelId, World};

/// The BabyAI level `id` (a registered id such as `BabyAI-GoToDoor-v0`).
pub fn babyai(id: &str) -> LevelConfig {
    LevelConfig::babyai(LevelId::parse(id).unwrap(), false)
}

/// The first views and tokenised missions of `count` episodes of `level` (seeds `0..count`).
pub fn first_views(level: &LevelConfig, count: u64) -> (Vec<Observation>, Vec<Vec<u32>>) {
    let worlds: Vec<World> = (0..count).map(|s| level.generate(s).unwrap()).collect();
    let obs = worlds.iter().map(World::observe).collect();
    let tokens = worlds
        .iter()
        .map(|w| groundscope::env::vocab::tokenize(&w.mission).unwrap())
        .collect();
    (obs, tokens)
}
