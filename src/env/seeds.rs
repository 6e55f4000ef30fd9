//! Level seeds: the one place that says which seeds belong to whom, so that no evaluation ever
//! runs a level a model was trained on and no two uses share a level.
//!
//! | use | level seeds |
//! |---|---|
//! | evaluation sweeps, replays (`eval`, `faithfulness`, `replay --seed`) | `s · 10⁶ + e` for evaluation seed `s` < [`MAX_EVAL_SEEDS`], episode `e` < 10⁶ |
//! | the trainer's tracked validation (`eval_log.csv`) | [`VALIDATION_SEED_BASE`] `+ e` |
//! | training | [`TRAIN_SEED_OFFSET`] `+ k` |
//!
//! The ranges are disjoint and in this order; the assertions below are checked when the crate
//! compiles.

/// Episodes per evaluation seed: the level seed of episode `e` of seed `s` is `s · 10⁶ + e`.
pub const EPISODES_PER_EVAL_SEED: u64 = 1_000_000;

/// Evaluation seeds are below this, so that their level seeds stay under the tracked
/// validation's.
pub const MAX_EVAL_SEEDS: u64 = 2147;

/// Level seeds of the tracked validation set are `VALIDATION_SEED_BASE + e`.
pub const VALIDATION_SEED_BASE: u64 = 1 << 31;

/// Level seeds used in training are `TRAIN_SEED_OFFSET + k`.
pub const TRAIN_SEED_OFFSET: u64 = 1 << 32;

const _: () = assert!(MAX_EVAL_SEEDS * EPISODES_PER_EVAL_SEED <= VALIDATION_SEED_BASE);
// A million validation episodes stay below the training seeds.
const _: () = assert!(VALIDATION_SEED_BASE + EPISODES_PER_EVAL_SEED < TRAIN_SEED_OFFSET);

/// The level seed of episode `e` of evaluation seed `s`: `s · 10⁶ + e`. `groundscope replay
/// --seed` takes it.
pub fn eval_level_seed(eval_seed: u64, episode: u64) -> u64 {
    eval_seed * EPISODES_PER_EVAL_SEED + episode
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_evaluation_level_stays_below_validation() {
        // The constants' order is asserted at compile time; this checks the function.
        let last_eval = eval_level_seed(MAX_EVAL_SEEDS - 1, EPISODES_PER_EVAL_SEED - 1);
        assert!(last_eval < VALIDATION_SEED_BASE);
        assert_eq!(eval_level_seed(3, 7), 3_000_007);
    }
}
