//! The ONNX model contract, version 1 (docs/onnx.md): the names a graph's inputs, outputs and
//! metadata must have, read from the protobuf before tract builds anything, so that every
//! defect is reported as one line naming the input, output, operator, key or word.

use std::collections::BTreeMap;

use serde::Deserialize;

use crate::env::level::{LevelConfig, LevelId};
use crate::env::vocab::VOCABULARY;
use crate::policy::error::PolicyError;

/// The contract version this build reads.
pub const CONTRACT: &str = "1";

/// Inputs the contract requires: the view. Everything else a policy reads is optional.
pub const REQUIRED_INPUTS: [&str; 1] = ["image"];
/// Inputs a model takes where it reads them: the mission (a model without text reads none)
/// and the recurrent state (a model without memory has none; then no `memory_out` either).
pub const STATE_INPUTS: [&str; 2] = ["mission", "memory"];
/// Inputs a graph may take: the agent's direction, and the pair that sets `M` for
/// interventions (`M' = (1 − α)·M + α·combined_override`, α = `override_weight`).
pub const OPTIONAL_INPUTS: [&str; 3] = ["direction", "combined_override", "override_weight"];
/// Outputs the contract requires.
pub const REQUIRED_OUTPUTS: [&str; 2] = ["logits", "value"];
/// How many actions `logits` may score: MiniGrid's seven, or its first three (left, right,
/// forward) — the action space of Dynamic-Obstacles, and what many MiniGrid agents are trained
/// with (lava crossings); no other prefix is a space an agent is trained on.
pub const ACTION_COUNTS: [usize; 2] = [7, 3];

/// The number of actions a graph's `logits` score, from its declared shape `(B, n)` (`None`
/// where a size is symbolic or the shape undeclared): `n` where it is one of
/// [`ACTION_COUNTS`], seven where the graph does not say; any other size is refused.
pub fn logits_width(dims: Option<&[Option<i64>]>) -> Result<usize, String> {
    let Some(Some(n)) = dims.and_then(|d| d.get(1)) else {
        return Ok(ACTION_COUNTS[0]);
    };
    match ACTION_COUNTS.iter().find(|&&k| k as i64 == *n) {
        Some(&k) => Ok(k),
        None => Err(format!(
            "output \"logits\" scores {n} actions; the contract wants 7 (MiniGrid's actions) or 3 (left, right, forward) on axis 1"
        )),
    }
}

/// The output of a graph with memory (it takes `memory` exactly when it outputs this).
pub const MEMORY_OUTPUT: &str = "memory_out";
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

/// Which of the inputs the contract leaves to the model a graph takes: what its metadata must
/// then describe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reads {
    /// It takes `mission`: its `vocabulary` is needed (else it may be left out).
    pub mission: bool,
    /// It takes `memory` and outputs `memory_out`: its `memory_size` is needed (else it is 0
    /// or left out).
    pub memory: bool,
}

impl Reads {
    /// A graph with a mission input and memory (every graph of the first contract).
    pub const ALL: Self = Self {
        mission: true,
        memory: true,
    };
}

/// What the metadata says about a model.
#[derive(Clone, Debug, PartialEq)]
pub struct Meta {
    /// A display name.
    pub name: String,
    /// The model's words, index = its token id (empty for a graph that reads no mission and
    /// names none).
    pub vocabulary: Vec<String>,
    /// M, the size of `memory` (0 for a graph without memory).
    pub memory_size: usize,
    /// The level it was trained on.
    pub level: LevelConfig,
    /// The maps' axis order.
    pub map_layout: MapLayout,
}

/// The metadata keys, without the `groundscope.` prefix, as strings (a sidecar's values may be
/// JSON values of any type; they are compared as the protobuf's strings would be).
pub type Props = BTreeMap<String, String>;

/// The `level` metadata: the paper's level by its five fields, or any registered level —
/// BabyAI's or MiniGrid's — by its id in `"babyai"`, beside which the five fields may be left
/// out (`{"babyai": "MiniGrid-DoorKey-5x5-v0"}`; `done_required` then defaults to false,
/// minigrid's registered mode, and the others are the id's own).
pub fn level_of(text: &str) -> Result<LevelConfig, String> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let value = match value {
        serde_json::Value::Object(given) if given.get("babyai").is_some_and(|v| !v.is_null()) => {
            let id: LevelId =
                serde_json::from_value(given["babyai"].clone()).map_err(|e| e.to_string())?;
            let serde_json::Value::Object(mut full) =
                serde_json::to_value(LevelConfig::babyai(id, false)).map_err(|e| e.to_string())?
            else {
                return Err("a level serialises as a JSON object".into());
            };
            // The fields given override the id's own; an unknown one is still refused below.
            full.extend(given);
            serde_json::Value::Object(full)
        }
        other => other,
    };
    serde_json::from_value(value).map_err(|e| e.to_string())
}

/// Reads `props` (protobuf metadata overridden by a sidecar's), naming the key that is
/// missing or wrong; `reads` says which keys the graph needs (a graph that reads no mission
/// needs no vocabulary, one without memory no `memory_size`).
pub fn meta(props: &Props, fallback_name: &str, reads: Reads) -> Result<Meta, PolicyError> {
    let missing = |key: &str, why: &str| {
        PolicyError::Input(format!(
            "metadata groundscope.{key} is missing{why} (docs/onnx.md lists the keys)"
        ))
    };
    let get = |key: &str| props.get(key).ok_or_else(|| missing(key, ""));
    let contract = get("contract")?;
    if contract.trim_matches('"') != CONTRACT {
        return Err(PolicyError::Input(format!(
            "metadata groundscope.contract is {contract}; this build reads contract {CONTRACT}"
        )));
    }
    let vocabulary: Vec<String> = match props.get("vocabulary") {
        None if !reads.mission => Vec::new(),
        None => return Err(missing("vocabulary", " (the graph takes \"mission\")")),
        Some(text) => serde_json::from_str(text).map_err(|e| {
            PolicyError::Input(format!(
                "metadata groundscope.vocabulary is not a JSON list of words: {e}"
            ))
        })?,
    };
    let memory_size = match props.get("memory_size") {
        None if !reads.memory => 0,
        None => return Err(missing("memory_size", " (the graph takes \"memory\")")),
        Some(text) => {
            let m: usize = text
                .trim_matches('"')
                .parse()
                .ok()
                .filter(|m| (usize::from(reads.memory)..=1 << 20).contains(m))
                .ok_or_else(|| {
                    PolicyError::Input(if reads.memory {
                        format!(
                            "metadata groundscope.memory_size = {text} must be a whole number \
                             in 1..=1048576"
                        )
                    } else {
                        format!("metadata groundscope.memory_size = {text} must be a whole number")
                    })
                })?;
            if !reads.memory && m != 0 {
                return Err(PolicyError::Input(format!(
                    "metadata groundscope.memory_size = {m}, but the graph has no input \
                     \"memory\": a graph without memory declares 0 or leaves the key out \
                     (docs/onnx.md#metadata)"
                )));
            }
            m
        }
    };
    let level = level_of(get("level")?)
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

    /// A graph of three actions (left, right, forward) is read as such; seven is the default
    /// where the size is symbolic; any other count is refused, naming the output.
    #[test]
    fn logits_score_seven_actions_or_the_first_three() {
        assert_eq!(logits_width(Some([None, Some(3)].as_slice())), Ok(3));
        assert_eq!(logits_width(Some([Some(1), Some(7)].as_slice())), Ok(7));
        assert_eq!(logits_width(Some([None, None].as_slice())), Ok(7));
        assert_eq!(logits_width(None), Ok(7));
        for n in [1i64, 5, 6, 8] {
            let e = logits_width(Some([None, Some(n)].as_slice())).unwrap_err();
            assert!(
                e.contains("output \"logits\"") && e.contains(&n.to_string()),
                "{e}"
            );
        }
    }

    #[test]
    fn complete_metadata_reads_and_defaults_the_layout() {
        let m = meta(&props(), "agent", Reads::ALL).unwrap();
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
            let e = meta(&p, "m", Reads::ALL).unwrap_err().to_string();
            assert!(e.contains(expect), "{key}: {e}");
        }
        let mut p = props();
        p.remove("memory_size");
        let e = meta(&p, "m", Reads::ALL).unwrap_err().to_string();
        assert!(e.contains("groundscope.memory_size is missing"), "{e}");
        let no_key: Vec<String> = VOCABULARY
            .iter()
            .filter(|w| **w != "key")
            .map(|w| (*w).to_owned())
            .collect();
        let e = token_map(&no_key, true).unwrap_err().to_string();
        assert!(e.contains("no word \"key\""), "{e}");
    }

    /// A graph that reads no mission needs no vocabulary, one without memory no
    /// `memory_size` (or 0); a memory size beside a graph without memory is named.
    #[test]
    fn a_graph_without_mission_or_memory_needs_neither_key() {
        let none = Reads {
            mission: false,
            memory: false,
        };
        let mut p = props();
        p.remove("vocabulary");
        p.remove("memory_size");
        let m = meta(&p, "m", none).unwrap();
        assert!(m.vocabulary.is_empty());
        assert_eq!(m.memory_size, 0);
        p.insert("memory_size".into(), "0".into());
        assert_eq!(meta(&p, "m", none).unwrap().memory_size, 0);
        p.insert("memory_size".into(), "8".into());
        let e = meta(&p, "m", none).unwrap_err().to_string();
        assert!(
            e.contains("memory_size = 8, but the graph has no input \"memory\""),
            "{e}"
        );
        let mut p = props();
        p.remove("vocabulary");
        let e = meta(&p, "m", Reads::ALL).unwrap_err().to_string();
        assert!(
            e.contains("groundscope.vocabulary is missing (the graph takes \"mission\")"),
            "{e}"
        );
    }

    /// A level names any registered id, MiniGrid's included, in `babyai`, with or without the
    /// paper's five fields beside it; an unknown id or field is refused.
    #[test]
    fn a_level_names_any_registered_id_alone() {
        let doorkey = level_of(r#"{"babyai": "MiniGrid-DoorKey-5x5-v0"}"#).unwrap();
        assert_eq!(doorkey.id(), "MiniGrid-DoorKey-5x5-v0");
        assert!(!doorkey.done_required);
        assert!(doorkey.validate().is_ok());
        let fetch = level_of(r#"{"babyai": "MiniGrid-Fetch-5x5-N2-v0"}"#).unwrap();
        assert_eq!(
            fetch,
            LevelConfig::babyai(LevelId::parse("MiniGrid-Fetch-5x5-N2-v0").unwrap(), false)
        );
        // The first contract's form, all five fields beside the id, reads as before.
        let full = r#"{"room_size": 8, "n_objects": 4, "tasks": "both", "done_required": false,
            "color_optional": true, "babyai": "BabyAI-GoToRedBallGrey-v0"}"#;
        let l = level_of(full).unwrap();
        assert_eq!((l.room_size, l.n_objects), (8, 4));
        assert_eq!(l.id(), "BabyAI-GoToRedBallGrey-v0");
        let done = level_of(r#"{"babyai": "BabyAI-GoToLocal-v0", "done_required": true}"#);
        assert!(done.unwrap().done_required);
        assert_eq!(
            level_of(&serde_json::to_string(&LevelConfig::default()).unwrap()).unwrap(),
            LevelConfig::default()
        );
        for (bad, expect) in [
            (
                r#"{"babyai": "MiniGrid-DoorKey-4x4-v0"}"#,
                "MiniGrid-DoorKey-4x4-v0",
            ),
            (
                r#"{"babyai": "MiniGrid-Empty-5x5-v0", "colour": 1}"#,
                "colour",
            ),
            (r#"{"room_size": 8}"#, "missing field"),
        ] {
            let e = level_of(bad).unwrap_err();
            assert!(e.contains(expect), "{bad}: {e}");
        }
        // minigrid's own environments have no done-action mode.
        let mut p = props();
        p.insert(
            "level".into(),
            r#"{"babyai": "MiniGrid-DoorKey-5x5-v0", "done_required": true}"#.into(),
        );
        assert!(meta(&p, "m", Reads::ALL).is_err());
    }
}
