//! Several levels in one run (`train --levels A,B:2,…`): each episode's level is drawn from a
//! weighted list.
//!
//! The draw is a function of the episode's training seed alone (a hash of it against the
//! cumulative weights), not of an RNG stream, so a resumed run and a run with another number
//! of environments meet the same level for the same seed, and nothing extra needs saving.

use serde::{Deserialize, Serialize};

use crate::env::level::{LevelConfig, LevelId};
use crate::policy::error::PolicyError;

/// One level of a mix and its weight.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MixEntry {
    /// The level.
    pub level: LevelConfig,
    /// Its share of the episodes, relative to the others' (positive).
    pub weight: f64,
}

/// The levels a run trains on: one, or a weighted list. Read back from a run's files through
/// [`LevelMix::new`]'s checks, as the flag is.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct LevelMix {
    entries: Vec<MixEntry>,
}

impl<'de> Deserialize<'de> for LevelMix {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Self::new(Vec::<MixEntry>::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

/// The range of a `--levels` weight: only ratios count, and within it the weights sum and
/// print as plain numbers (a weight of 1e308 would make the sum infinite and change the mix).
pub const WEIGHT_RANGE: std::ops::RangeInclusive<f64> = 1e-6..=1e6;

impl From<LevelConfig> for LevelMix {
    fn from(level: LevelConfig) -> Self {
        Self {
            entries: vec![MixEntry { level, weight: 1.0 }],
        }
    }
}

impl LevelMix {
    /// A mix of `entries`, refusing an empty list, a repeated level or a weight that is not a
    /// positive number.
    pub fn new(entries: Vec<MixEntry>) -> Result<Self, PolicyError> {
        if entries.is_empty() {
            return Err(PolicyError::Input("--levels: no level given".into()));
        }
        for (i, e) in entries.iter().enumerate() {
            if !WEIGHT_RANGE.contains(&e.weight) {
                return Err(PolicyError::Input(format!(
                    "--levels: {}: weight {:?} must be a positive number from {:e} to {:e} (only the ratios count)",
                    e.level,
                    e.weight,
                    WEIGHT_RANGE.start(),
                    WEIGHT_RANGE.end()
                )));
            }
            e.level.validate()?;
            if entries[..i].iter().any(|o| o.level == e.level) {
                return Err(PolicyError::Input(format!(
                    "--levels: {} is listed twice",
                    e.level
                )));
            }
        }
        Ok(Self { entries })
    }

    /// Parses `--levels`: registered ids separated by commas, each optionally followed by
    /// `:WEIGHT` (default 1), all in the registered mode or, with `done`, in the paper's
    /// done-action mode.
    pub fn parse(list: &str, done: bool) -> Result<Self, PolicyError> {
        let mut entries = Vec::new();
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (id, weight) = match item.split_once(':') {
                Some((id, w)) => {
                    let weight = w.trim().parse::<f64>().map_err(|_| {
                        PolicyError::Input(format!(
                            "--levels: {id}: weight {w:?} is not a number (write ID:WEIGHT)"
                        ))
                    })?;
                    (id.trim(), weight)
                }
                None => (item, 1.0),
            };
            let id = LevelId::parse(id)?;
            entries.push(MixEntry {
                level: LevelConfig::babyai(id, done),
                weight,
            });
        }
        Self::new(entries)
    }

    /// The levels and weights, in the order given.
    pub fn entries(&self) -> &[MixEntry] {
        &self.entries
    }

    /// The first level listed: the one a checkpoint of the run names as its own (the level
    /// `view` and `eval` open by default).
    pub fn first(&self) -> LevelConfig {
        self.entries[0].level
    }

    /// Whether the run trains on more than one level.
    pub fn is_mix(&self) -> bool {
        self.entries.len() > 1
    }

    /// The level of the episode on training seed `k` (counted from the first training seed).
    pub fn pick(&self, k: u64) -> LevelConfig {
        self.entries[self.pick_entry(k)].level
    }

    /// The index of the entry [`Self::pick`] draws for training seed `k`.
    pub fn pick_entry(&self, k: u64) -> usize {
        if self.entries.len() == 1 {
            return 0;
        }
        let total: f64 = self.entries.iter().map(|e| e.weight).sum();
        // 53 bits of a well-mixed hash: a uniform draw in [0, 1).
        let u = (splitmix64(k) >> 11) as f64 / (1u64 << 53) as f64 * total;
        let mut acc = 0.0;
        for (i, e) in self.entries.iter().enumerate() {
            acc += e.weight;
            if u < acc {
                return i;
            }
        }
        self.entries.len() - 1
    }
}

impl std::fmt::Display for LevelMix {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, e) in self.entries.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{}", e.level)?;
            if self.is_mix() && e.weight != 1.0 {
                write!(f, " ×{}", e.weight)?;
            }
        }
        Ok(())
    }
}

/// SplitMix64's output function: consecutive seeds give independent-looking draws.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_follow_the_weights_and_depend_on_the_seed_only() {
        let mix = LevelMix::parse("BabyAI-GoToLocal-v0:3, BabyAI-PickupLoc-v0", false).unwrap();
        let n = 40_000;
        let first = (0..n).filter(|&k| mix.pick(k) == mix.first()).count();
        let share = first as f64 / n as f64;
        assert!((share - 0.75).abs() < 0.01, "{share}");
        assert_eq!(
            (0..50).map(|k| mix.pick(k)).collect::<Vec<_>>(),
            (0..50).map(|k| mix.pick(k)).collect::<Vec<_>>()
        );
        assert!(mix.to_string().contains("×3"), "{mix}");
    }

    #[test]
    fn a_saved_mix_is_checked_as_the_flag_is() {
        let mix = LevelMix::parse("BabyAI-GoToLocal-v0:3, BabyAI-PickupLoc-v0", false).unwrap();
        let json = serde_json::to_string(&mix).unwrap();
        assert_eq!(serde_json::from_str::<LevelMix>(&json).unwrap(), mix);
        for (bad, says) in [
            (json.replace("3.0", "-3.0"), "positive"),
            (json.replace("PickupLoc", "GoToLocal"), "twice"),
            ("[]".to_owned(), "no level"),
        ] {
            let e = serde_json::from_str::<LevelMix>(&bad)
                .unwrap_err()
                .to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn bad_lists_are_refused_naming_the_item() {
        for (list, says) in [
            ("", "no level"),
            ("BabyAI-GoToLocal-v0:0", "positive"),
            ("BabyAI-GoToLocal-v0:1e308,BabyAI-PickupLoc-v0:1e308", "1e6"),
            ("BabyAI-GoToLocal-v0:1e-300", "positive"),
            ("BabyAI-GoToLocal-v0:nan", "positive"),
            ("BabyAI-GoToLocal-v0:x", "\"x\""),
            ("BabyAI-GoToLocal-v0,BabyAI-GoToLocal-v0", "twice"),
            ("BabyAI-Nope-v0", "BabyAI-Nope-v0"),
        ] {
            let e = LevelMix::parse(list, false).unwrap_err().to_string();
            assert!(e.contains(says), "{list}: {e}");
        }
    }
}
