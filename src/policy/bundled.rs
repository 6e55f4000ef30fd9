//! The checkpoints shipped in `assets/` and embedded in the binary: the paper's pair, the
//! default of every command (`bundled:attention` first, then `bundled:baseline`),
//! `bundled:babyai`, an attention model that reads BabyAI's whole grammar, and
//! `bundled:babyai-grounded`, its continuation whose maps were supervised to ground, and
//! `bundled:babyai-grounded2`, a later continuation whose maps ground further (every class but
//! location words at the targets) at the same success.

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
        "babyai-grounded",
        include_str!("../../assets/babyai-grounded.json"),
        include_bytes!("../../assets/babyai-grounded.safetensors"),
    ),
    (
        "babyai-grounded2",
        include_str!("../../assets/babyai-grounded2.json"),
        include_bytes!("../../assets/babyai-grounded2.safetensors"),
    ),
];

/// The bundled model for BabyAI's levels: it reads every word of their missions.
pub const BABYAI: &str = "bundled:babyai";

/// `bundled:babyai` continued with the layout path and supervised maps: the recipe the layout
/// path study's rule chose (experiments/study_layout_path/).
pub const BABYAI_GROUNDED: &str = "bundled:babyai-grounded";

/// `bundled:babyai` continued with the layout path, the filter at the view's scale and
/// supervised maps for 3M frames: the recipe the filter norm study's rule chose
/// (experiments/study_filter_norm/), the most grounded at the success floor.
pub const BABYAI_GROUNDED2: &str = "bundled:babyai-grounded2";

/// How a bundled checkpoint was trained, where its metadata (which names one level) would
/// not say it truly; `None` for any other name.
pub fn training_note(spec: &str) -> Option<&'static str> {
    match spec {
        BABYAI => Some(
            "imitation of minigrid's BabyAI bot on sixteen BabyAI levels at once (experiments/babyai_agent/levels.txt)",
        ),
        BABYAI_GROUNDED => Some(
            "bundled:babyai continued by imitation on its sixteen levels with the layout path (experiments/study_layout_path/)",
        ),
        BABYAI_GROUNDED2 => Some(
            "bundled:babyai continued by imitation on its sixteen levels with the layout path and the filter norm (experiments/study_filter_norm/)",
        ),
        _ => None,
    }
}

/// The paper's pair, `bundled:attention` then `bundled:baseline`: what `eval`, `replay` and
/// `faithfulness` run without `--checkpoint`.
pub fn pair() -> Vec<String> {
    names().into_iter().take(2).collect()
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
            if [BABYAI, BABYAI_GROUNDED, BABYAI_GROUNDED2].contains(&n.as_str()) {
                assert_eq!(variant, "attention");
                assert_eq!(
                    c.meta.model.vocab_size,
                    crate::env::vocab::BABYAI_VOCAB_SIZE
                );
                assert_eq!(c.meta.model.layout_path, n != BABYAI);
                assert_eq!(c.meta.model.filter_norm, n == BABYAI_GROUNDED2);
                assert!(training_note(&n).is_some());
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
}
