//! The checkpoints shipped in `assets/` and embedded in the binary: the paper's pair, the
//! default of every command (`bundled:attention` first, then `bundled:baseline`), and
//! `bundled:babyai`, an attention model that reads BabyAI's whole grammar.

use std::path::Path;

use super::checkpoint::Checkpoint;
use super::error::PolicyError;

/// Prefix that names an embedded checkpoint on the command line.
pub const PREFIX: &str = "bundled:";

/// The embedded checkpoints: name, JSON, weights.
const BUNDLED: [(&str, &str, &[u8]); 3] = [
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
];

/// The bundled model for BabyAI's levels: it reads every word of their missions.
pub const BABYAI: &str = "bundled:babyai";

/// How a bundled checkpoint was trained, where its metadata (which names one level) would
/// not say it truly; `None` for any other name.
pub fn training_note(spec: &str) -> Option<&'static str> {
    (spec == BABYAI).then_some(
        "imitation of minigrid's BabyAI bot on sixteen BabyAI levels at once (experiments/babyai_agent/levels.txt)",
    )
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
            if n == BABYAI {
                assert_eq!(variant, "attention");
                assert_eq!(c.meta.model.vocab_size, crate::env::vocab::VOCAB_SIZE);
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
