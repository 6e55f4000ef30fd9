//! The checkpoints shipped in `assets/` and embedded in the binary: the paper's pair, the
//! default of every command (`bundled:attention` first, then `bundled:baseline`);
//! `bundled:babyai`, an attention model that reads BabyAI's whole grammar and whose maps were
//! supervised to ground (the filter norm study's choice); and MiniGrid's pair,
//! `bundled:minigrid` and `bundled:minigrid-baseline`, distilled beside each other by one
//! recipe from the best model of each of fourteen of MiniGrid's own ids, the attention model's
//! maps supervised to ground (the MiniGrid study's choice), the default on any `MiniGrid-*`
//! id. The names BabyAI's model had before keep working or say what replaced them
//! ([`alias`]).

use std::path::Path;

use super::checkpoint::Checkpoint;
use super::error::PolicyError;

/// Prefix that names an embedded checkpoint on the command line.
pub const PREFIX: &str = "bundled:";

/// The embedded checkpoints: name, JSON, weights.
const BUNDLED: [(&str, &str, &[u8]); 5] = [
    (
        "attention",
        include_str!("../../assets/attention.json"),
        include_bytes!("../../assets/attention.safetensors"),
    ),
    (
        "baseline",
        include_str!("../../assets/baseline.json"),
        include_bytes!("../../assets/baseline.safetensors"),
    ),
    (
        "babyai",
        include_str!("../../assets/babyai.json"),
        include_bytes!("../../assets/babyai.safetensors"),
    ),
    (
        "minigrid",
        include_str!("../../assets/minigrid.json"),
        include_bytes!("../../assets/minigrid.safetensors"),
    ),
    (
        "minigrid-baseline",
        include_str!("../../assets/minigrid-baseline.json"),
        include_bytes!("../../assets/minigrid-baseline.safetensors"),
    ),
];

/// The bundled model for BabyAI's levels: it reads every word of their missions, and its maps
/// were supervised to ground (`training.ground_loss` in its metadata).
pub const BABYAI: &str = "bundled:babyai";

/// The bundled attention model for MiniGrid's own ids: it reads all of groundscope's words
/// (MiniGrid's missions and BabyAI's), and its maps were supervised to ground
/// (`training.ground_loss` in its metadata).
pub const MINIGRID: &str = "bundled:minigrid";

/// The no-attention baseline trained beside [`MINIGRID`] by the same recipe.
pub const MINIGRID_BASELINE: &str = "bundled:minigrid-baseline";

/// What MiniGrid's pair was trained on, said once for both names.
const MINIGRID_NOTE: &str = "imitation of the best model of each of fourteen of MiniGrid's own ids at once (`--imitate --teacher`; experiments/study_minigrid/, stages 8 to 10: 4,608,000 frames, pure cloning then DAgger, `--imitate-policy-share 0.5`), the attention model's maps supervised to ground (`--ground-loss 0.1`)";

/// A name that opened a bundled checkpoint before 2026-12-02, when three BabyAI agents became
/// one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Alias {
    /// The name opens `now`, the same weights under their new name.
    Renamed {
        /// The name it opens now.
        now: &'static str,
    },
    /// The weights are no longer bundled; `replacement` is what to use instead.
    Removed {
        /// What replaces it.
        replacement: &'static str,
        /// Where the old weights can still be had.
        history: &'static str,
    },
}

/// What an old bundled name stands for now; `None` for any current name or other spec.
pub fn alias(spec: &str) -> Option<Alias> {
    match spec {
        "bundled:babyai-grounded2" => Some(Alias::Renamed { now: BABYAI }),
        "bundled:babyai-grounded" => Some(Alias::Removed {
            replacement: BABYAI,
            history: "git show c848d4d:assets/babyai-grounded.safetensors",
        }),
        _ => None,
    }
}

impl std::fmt::Display for Alias {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Renamed { now } => write!(f, "it is {now} now (the same weights)"),
            Self::Removed {
                replacement,
                history,
            } => write!(
                f,
                "it is no longer bundled; {replacement}, its continuation, grounds further and \
                 replaces it (the old weights: `{history}`)"
            ),
        }
    }
}

/// How a bundled checkpoint was trained, where its metadata (which names one level) would
/// not say it truly; `None` for any other name.
pub fn training_note(spec: &str) -> Option<&'static str> {
    match spec {
        BABYAI => Some(
            "imitation of minigrid's BabyAI bot on sixteen BabyAI levels at once (experiments/babyai_agent/levels.txt), continued with the layout path, the filter norm and supervised maps (experiments/study_filter_norm/)",
        ),
        MINIGRID | MINIGRID_BASELINE => Some(MINIGRID_NOTE),
        _ => None,
    }
}

/// The paper's pair, `bundled:attention` then `bundled:baseline`: what `eval`, `replay` and
/// `faithfulness` run without `--checkpoint`.
pub fn pair() -> Vec<String> {
    names().into_iter().take(2).collect()
}

/// MiniGrid's pair, [`MINIGRID`] then [`MINIGRID_BASELINE`]: what `eval` runs without
/// `--checkpoint` on MiniGrid's own ids.
pub fn minigrid_pair() -> Vec<String> {
    vec![MINIGRID.to_owned(), MINIGRID_BASELINE.to_owned()]
}

/// The bundled baseline trained beside the bundled model `name`: what it is compared with by
/// default. MiniGrid's pair for `bundled:minigrid`, the paper's baseline for any other name.
pub fn baseline_beside(name: &str) -> &'static str {
    if name == MINIGRID {
        MINIGRID_BASELINE
    } else {
        "bundled:baseline"
    }
}

/// Names of the embedded checkpoints, default first.
pub fn names() -> Vec<String> {
    BUNDLED
        .iter()
        .map(|(n, _, _)| format!("{PREFIX}{n}"))
        .collect()
}

/// Loads a checkpoint named `bundled:NAME` or stored at a path (`NAME`, `NAME.json` or
/// `NAME.safetensors`).
pub fn load(spec: &str) -> Result<Checkpoint, PolicyError> {
    let Some(name) = spec.strip_prefix(PREFIX) else {
        return Checkpoint::load(Path::new(spec));
    };
    let name = match alias(spec) {
        Some(Alias::Renamed { now }) => now.trim_start_matches(PREFIX),
        Some(removed @ Alias::Removed { .. }) => {
            return Err(PolicyError::Input(format!("{spec}: {removed}")));
        }
        None => name,
    };
    let Some((_, json, weights)) = BUNDLED.iter().find(|(n, _, _)| *n == name) else {
        return Err(PolicyError::Input(format!(
            "no bundled checkpoint {spec:?}; the bundled ones are {}",
            names().join(", ")
        )));
    };
    Checkpoint::from_parts(
        json,
        weights,
        Path::new(&format!("assets/{name}.json")),
        Path::new(&format!("assets/{name}.safetensors")),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bundled_checkpoint_loads_and_matches_its_name() {
        for n in names() {
            let c = load(&n).unwrap();
            let variant = c.meta.model.variant.name();
            if n == BABYAI {
                assert_eq!(variant, "attention");
                assert_eq!(
                    c.meta.model.vocab_size,
                    crate::env::vocab::BABYAI_VOCAB_SIZE
                );
                assert!(c.meta.model.layout_path && c.meta.model.filter_norm);
                assert!(c.meta.training.ground_loss.is_some());
                assert!(training_note(&n).is_some());
            } else if n == MINIGRID || n == MINIGRID_BASELINE {
                let want = if n == MINIGRID {
                    "attention"
                } else {
                    "baseline"
                };
                assert_eq!(variant, want, "{n}");
                assert_eq!(c.meta.model.vocab_size, crate::env::vocab::VOCAB_SIZE);
                // The attention model's maps were supervised; a baseline has none.
                let supervised = c.meta.training.ground_loss.is_some();
                assert_eq!(supervised, n == MINIGRID, "{n}");
                assert!(c.meta.level.is_minigrid());
                assert_eq!(training_note(&n), Some(MINIGRID_NOTE));
                // The note says how long the embedded weights trained.
                let said = format!("{} frames", c.meta.training.frames);
                assert!(
                    MINIGRID_NOTE.replace(',', "").contains(&said),
                    "{n}: {said}"
                );
            } else {
                assert_eq!(format!("{PREFIX}{variant}"), n);
            }
        }
        assert!(
            load("bundled:transformer")
                .unwrap_err()
                .to_string()
                .contains("bundled:attention")
        );
    }

    #[test]
    fn old_names_open_their_weights_or_name_the_replacement() {
        let renamed = load("bundled:babyai-grounded2").unwrap();
        assert_eq!(
            renamed.meta.weights_sha256,
            load(BABYAI).unwrap().meta.weights_sha256
        );
        let removed = load("bundled:babyai-grounded").unwrap_err().to_string();
        assert!(removed.contains("bundled:babyai,"), "{removed}");
        assert!(removed.contains("git show"), "{removed}");
        assert_eq!(alias(BABYAI), None);
    }

    #[test]
    fn minigrids_pair_was_trained_together() {
        let [a, b] = [MINIGRID, MINIGRID_BASELINE].map(|n| load(n).unwrap().meta);
        assert_eq!(a.level.babyai, b.level.babyai);
        assert_eq!(a.training.frames, b.training.frames);
        assert_eq!(a.training.seed, b.training.seed);
        assert_eq!(minigrid_pair(), [MINIGRID, MINIGRID_BASELINE]);
        assert_eq!(baseline_beside(MINIGRID), MINIGRID_BASELINE);
        assert_eq!(baseline_beside(BABYAI), pair()[1]);
    }
}
