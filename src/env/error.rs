//! Errors of the world: invalid configs, states, dumps and missions.

use thiserror::Error;

/// Everything that can go wrong in `env`; every variant names the field or word at fault.
#[derive(Debug, Error)]
pub enum EnvError {
    /// A level configuration that cannot be generated.
    #[error("invalid level config: {field}: {reason}")]
    InvalidConfig {
        /// The offending field, e.g. `room_size`.
        field: String,
        /// Why.
        reason: String,
    },
    /// A world state that is inconsistent.
    #[error("invalid state: {field}: {reason}")]
    InvalidState {
        /// The offending field, e.g. `agent_pos`.
        field: String,
        /// Why.
        reason: String,
    },
    /// A snapshot / dump that does not parse or is out of range.
    #[error("invalid snapshot: {field}: {reason}")]
    InvalidSnapshot {
        /// JSON path of the offending field, e.g. `grid[3][4]`.
        field: String,
        /// Why.
        reason: String,
    },
    /// A mission word outside the vocabulary.
    #[error(
        "unknown word {} in mission {} (vocabulary: {vocabulary})",
        shown(word),
        shown(mission)
    )]
    UnknownWord {
        /// The word.
        word: String,
        /// The whole mission.
        mission: String,
        /// The known words, space-separated.
        vocabulary: String,
    },
    /// A level's mission with a word outside the vocabulary.
    #[error(
        "unknown word {} in mission {} of level {level}: the agent's vocabulary does not cover it",
        shown(word),
        shown(mission)
    )]
    UnknownWordOnLevel {
        /// The word.
        word: String,
        /// The whole mission.
        mission: String,
        /// The level (and seed).
        level: String,
    },
    /// A mission text that names no object of the world or is not a BabyAI instruction.
    #[error("invalid mission {}: {reason}", shown(mission))]
    InvalidMission {
        /// The mission text.
        mission: String,
        /// Why.
        reason: String,
    },
    /// `step` after the episode ended, without a reset.
    #[error("the episode ended at step {step_count}; reset before stepping again")]
    EpisodeEnded {
        /// Steps taken when it ended.
        step_count: u32,
    },
    /// Level generation kept failing (rejection sampling exhausted).
    #[error("could not generate a level for seed {seed} after {tries} tries")]
    GenerationFailed {
        /// The seed.
        seed: u64,
        /// Attempts made.
        tries: u32,
    },
    /// minigrid 3.2.0 itself never finishes generating this level (a loop no draw can end).
    #[error(
        "{level} seed {seed} cannot be generated: minigrid 3.2.0 loops forever on it ({why}); try another seed"
    )]
    GenerationHangs {
        /// The level id.
        level: String,
        /// The seed.
        seed: u64,
        /// Where it loops.
        why: &'static str,
    },
}

/// Text from the user as an error shows it: quoted, control characters escaped (a terminal
/// never receives them raw), and cut after 80 characters.
pub fn shown(text: &str) -> String {
    const MAX: usize = 80;
    let mut out = String::from("\"");
    for (i, c) in text.chars().enumerate() {
        if i == MAX {
            return format!("{out}…\" ({} characters)", text.chars().count());
        }
        if c.is_control() || c == '"' {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn user_text_is_escaped_and_cut() {
        assert_eq!(shown("go to the red key"), "\"go to the red key\"");
        assert_eq!(shown("go \u{1b}[31mred"), "\"go \\u{1b}[31mred\"");
        let long = "a".repeat(10_000);
        let s = shown(&long);
        assert!(s.len() < 120 && s.ends_with("(10000 characters)"), "{s}");
    }
}
