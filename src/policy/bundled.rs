//! The checkpoints shipped in `assets/` and embedded in the binary: the default of every
//! command (`bundled:attention` first, then `bundled:baseline`).

use std::path::Path;

use super::checkpoint::Checkpoint;
use super::error::PolicyError;

/// Prefix that names an embedded checkpoint on the command line.
pub const PREFIX: &str = "bundled:";

/// The embedded checkpoints: name, JSON, weights.
const BUNDLED: [(&str, &str, &[u8]); 2] = [
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
];

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
            assert_eq!(format!("{PREFIX}{}", c.meta.model.variant.name()), n);
        }
        assert!(
            load("bundled:transformer")
                .unwrap_err()
                .to_string()
                .contains("bundled:attention")
        );
    }
}
