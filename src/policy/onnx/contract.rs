//! The ONNX model contract, version 1 (docs/onnx.md): the names a graph's inputs, outputs and
//! metadata must have, read from the protobuf before tract builds anything, so that every
//! defect is reported as one line naming the input, output, operator, key or word.

use std::collections::BTreeMap;

use serde::Deserialize;

use crate::env::level::LevelConfig;
use crate::env::vocab::VOCABULARY;
use crate::policy::error::PolicyError;

/// The contract version this build reads.
pub const CONTRACT: &str = "1";

/// Inputs the contract requires.
pub const REQUIRED_INPUTS: [&str; 3] = ["image", "mission", "memory"];
/// Inputs a graph may take: the agent's direction, and the pair that sets `M` for
/// interventions (`M' = (1 − α)·M + α·combined_override`, α = `override_weight`).
pub const OPTIONAL_INPUTS: [&str; 3] = ["direction", "combined_override", "override_weight"];
/// Outputs the contract requires.
pub const REQUIRED_OUTPUTS: [&str; 3] = ["logits", "value", "memory_out"];
/// Outputs groundscope shows when a graph has them.
pub const OPTIONAL_OUTPUTS: [&str; 3] = ["word_maps", "word_weights", "combined_map"];

/// The metadata keys the contract reads (`groundscope.KEY` in the graph, `KEY` in a sidecar).
pub const METADATA_KEYS: [&str; 6] = [
    "contract",
    "vocabulary",
    "memory_size",
    "level",
    "map_layout",
    "name",
];

/// ONNX's element type codes that the contract admits.
pub const ONNX_FLOAT: i32 = 1;
/// ONNX `INT64`.
pub const ONNX_INT64: i32 = 7;

/// How a graph's maps are laid out over the view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MapLayout {
    /// The same axis order as `image`: `[vx][vy]`, flat `vx·7 + vy` (the default).
    Image,
    /// groundscope's own trace order: `[vy][vx]`, flat `vy·7 + vx`.
    AgentUp,
}

/// What the metadata says about a model.
#[derive(Clone, Debug, PartialEq)]
pub struct Meta {
    /// A display name.
    pub name: String,
    /// The model's words, index = its token id.
    pub vocabulary: Vec<String>,
    /// M, the size of `memory`.
    pub memory_size: usize,
    /// The level it was trained on.
    pub level: LevelConfig,
    /// The maps' axis order.
    pub map_layout: MapLayout,
}

/// The metadata keys, without the `groundscope.` prefix, as strings (a sidecar's values may be
/// JSON values of any type; they are compared as the protobuf's strings would be).
pub type Props = BTreeMap<String, String>;

/// Reads `props` (protobuf metadata overridden by a sidecar's), naming the key that is
/// missing or wrong.
pub fn meta(props: &Props, fallback_name: &str) -> Result<Meta, PolicyError> {
    let get = |key: &str| {
        props.get(key).ok_or_else(|| {
            PolicyError::Input(format!(
                "metadata groundscope.{key} is missing (docs/onnx.md lists the keys)"
            ))
        })
    };
    let contract = get("contract")?;
    if contract.trim_matches('"') != CONTRACT {
        return Err(PolicyError::Input(format!(
            "metadata groundscope.contract is {contract}; this build reads contract {CONTRACT}"
        )));
    }
    let vocabulary: Vec<String> = serde_json::from_str(get("vocabulary")?).map_err(|e| {
        PolicyError::Input(format!(
            "metadata groundscope.vocabulary is not a JSON list of words: {e}"
        ))
    })?;
    let memory_size: usize = get("memory_size")?
        .trim_matches('"')
        .parse()
        .ok()
        .filter(|m| (1..=1 << 20).contains(m))
        .ok_or_else(|| {
            PolicyError::Input(format!(
                "metadata groundscope.memory_size = {} must be a whole number in 1..=1048576",
                props["memory_size"]
            ))
        })?;
    let level: LevelConfig = serde_json::from_str(get("level")?)
        .map_err(|e| PolicyError::Input(format!("metadata groundscope.level: {e}")))?;
    level
        .validate()
        .map_err(|e| PolicyError::Input(format!("metadata groundscope.level: {e}")))?;
    let map_layout = match props.get("map_layout").map(|s| s.trim_matches('"')) {
        None | Some("image") => MapLayout::Image,
        Some("agent-up") => MapLayout::AgentUp,
        Some(other) => {
            return Err(PolicyError::Input(format!(
                "metadata groundscope.map_layout = {other} must be image or agent-up"
            )));
        }
    };
    let name = props
        .get("name")
        .map_or(fallback_name, |s| s.trim_matches('"'))
        .to_owned();
    Ok(Meta {
        name,
        vocabulary,
        memory_size,
        level,
        map_layout,
    })
}

/// Words the paper's level's missions use: every word of its vocabulary but padding, BabyAI's
/// "object" and the location phrases of its `PickupLoc`, which that level never generates.
pub fn mission_words() -> impl Iterator<Item = (u32, &'static str)> {
    const NEVER: [&str; 10] = [
        "object", "in", "front", "of", "you", "behind", "on", "your", "left", "right",
    ];
    VOCABULARY[..crate::env::vocab::PAPER_VOCAB_SIZE]
        .iter()
        .enumerate()
        .skip(1)
        .filter(|(_, w)| !NEVER.contains(w))
        .map(|(i, w)| (i as u32, *w))
}

/// Our token id → the model's, for every word of our vocabulary the model's has (others
/// `None`, named when a mission holds one). A graph trained on the paper's level
/// (`paper_words`) must know every word those missions use, checked here, at load; a graph of a
/// BabyAI level only the words its missions hold, checked at the first such mission.
pub fn token_map(
    vocabulary: &[String],
    paper_words: bool,
) -> Result<Vec<Option<i64>>, PolicyError> {
    let theirs = |word: &str| {
        vocabulary
            .iter()
            .position(|w| w.eq_ignore_ascii_case(word))
            .map(|i| i as i64)
    };
    if paper_words && let Some((_, word)) = mission_words().find(|(_, w)| theirs(w).is_none()) {
        return Err(PolicyError::Input(format!(
            "metadata groundscope.vocabulary has no word \"{word}\", which missions use"
        )));
    }
    Ok(VOCABULARY
        .iter()
        .enumerate()
        .map(|(i, w)| if i == 0 { None } else { theirs(w) })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn props() -> Props {
        let words: Vec<&str> = VOCABULARY.to_vec();
        [
            ("contract", "1".to_owned()),
            ("vocabulary", serde_json::to_string(&words).unwrap()),
            ("memory_size", "256".to_owned()),
            (
                "level",
                serde_json::to_string(&LevelConfig::default()).unwrap(),
            ),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v))
        .collect()
    }

    #[test]
    fn complete_metadata_reads_and_defaults_the_layout() {
        let m = meta(&props(), "agent").unwrap();
        assert_eq!(m.memory_size, 256);
        assert_eq!(m.map_layout, MapLayout::Image);
        assert_eq!(m.name, "agent");
        assert_eq!(m.level, LevelConfig::default());
        let map = token_map(&m.vocabulary, true).unwrap();
        assert_eq!(map[9], Some(9), "key keeps its id in our own vocabulary");
    }

    #[test]
    fn each_defect_names_its_key_or_word() {
        for (key, value, expect) in [
            ("contract", "2", "groundscope.contract is 2"),
            ("memory_size", "0", "groundscope.memory_size = 0"),
            ("memory_size", "lots", "groundscope.memory_size = lots"),
            ("vocabulary", "[1, 2", "groundscope.vocabulary is not"),
            ("level", "{}", "groundscope.level"),
            ("map_layout", "sideways", "map_layout = sideways"),
        ] {
            let mut p = props();
            p.insert(key.to_owned(), value.to_owned());
            let e = meta(&p, "m").unwrap_err().to_string();
            assert!(e.contains(expect), "{key}: {e}");
        }
        let mut p = props();
        p.remove("memory_size");
        let e = meta(&p, "m").unwrap_err().to_string();
        assert!(e.contains("groundscope.memory_size is missing"), "{e}");
        let no_key: Vec<String> = VOCABULARY
            .iter()
            .filter(|w| **w != "key")
            .map(|w| (*w).to_owned())
            .collect();
        let e = token_map(&no_key, true).unwrap_err().to_string();
        assert!(e.contains("no word \"key\""), "{e}");
    }
}
