//! The fixed mission vocabulary and BabyAI's tokenizer.
//!
//! BabyAI assigns word ids in first-seen order; we fix one table instead so that checkpoints
//! are portable. Id 0 is padding; ids 1..=25 cover every GoTo / Pickup mission BabyAI's local
//! levels produce, location phrases and "object" included (the paper's vocabulary, all a
//! checkpoint trained on the paper's level knows); ids 26..=32 add the rest of BabyAI's
//! grammar — Open, PutNext, doors and the sequences — and ids 33..=53 the words of MiniGrid's
//! own missions ("get to the green goal square", "avoid the lava", "put … near …", …), each
//! block appended so that every earlier id keeps its meaning.

use super::error::EnvError;

/// The padding id.
pub const PAD: u32 = 0;

/// The vocabulary, index = token id; index 0 is the padding token `<pad>`.
pub const VOCABULARY: [&str; 54] = [
    "<pad>", "a", "the", "go", "to", "pick", "up", "ball", "box", "key", "object", "red", "green",
    "blue", "purple", "yellow", "grey", "in", "front", "of", "you", "behind", "on", "your", "left",
    "right", "open", "door", "put", "next", "then", "after", "and", "get", "goal", "square", "use",
    "reach", "avoid", "lava", "find", "opening", "fetch", "must", "near", "from", "room", "unlock",
    "matching", "at", "end", "hallway", "traverse", "rooms",
];

/// How many entries of [`VOCABULARY`] (padding included) the paper's level uses: the
/// vocabulary of every checkpoint trained on it, and of every checkpoint made before BabyAI's
/// whole grammar was added.
pub const PAPER_VOCAB_SIZE: usize = 26;

/// How many entries BabyAI's whole grammar uses: the vocabulary of a checkpoint trained on
/// BabyAI's levels (and of every one made before MiniGrid's words were added).
pub const BABYAI_VOCAB_SIZE: usize = 33;

/// Vocabulary size including padding (the embedding table's rows of a model trained on
/// MiniGrid's own environments).
pub const VOCAB_SIZE: usize = VOCABULARY.len();

/// The id of `word`, if it is in the vocabulary (padding excluded).
pub fn token_id(word: &str) -> Option<u32> {
    VOCABULARY
        .iter()
        .skip(1)
        .position(|w| *w == word)
        .map(|i| i as u32 + 1)
}

/// The word of token `id` (`"<pad>"` for 0), if any.
pub fn word(id: u32) -> Option<&'static str> {
    VOCABULARY.get(id as usize).copied()
}

/// The words of a token sequence (`?` for an id outside the vocabulary).
pub fn words(tokens: &[u32]) -> Vec<&'static str> {
    tokens.iter().map(|&t| word(t).unwrap_or("?")).collect()
}

/// BabyAI's split: lowercase, then maximal runs of `a`–`z` (everything else separates).
pub fn split_words(mission: &str) -> Vec<String> {
    let lower = mission.to_lowercase();
    lower
        .split(|c: char| !c.is_ascii_lowercase())
        .filter(|w| !w.is_empty())
        .map(str::to_owned)
        .collect()
}

/// Token ids of `mission`; an unknown word is an error that names it and lists the vocabulary.
pub fn tokenize(mission: &str) -> Result<Vec<u32>, EnvError> {
    split_words(mission)
        .into_iter()
        .map(|w| {
            token_id(&w).ok_or_else(|| EnvError::UnknownWord {
                word: w.clone(),
                mission: mission.to_owned(),
                vocabulary: VOCABULARY[1..].join(" "),
            })
        })
        .collect()
}

/// [`tokenize`] for a level's own mission: an unknown word names the level too.
pub fn tokenize_on_level(
    mission: &str,
    level: impl FnOnce() -> String,
) -> Result<Vec<u32>, EnvError> {
    tokenize(mission).map_err(|e| match e {
        EnvError::UnknownWord { word, mission, .. } => EnvError::UnknownWordOnLevel {
            word,
            mission,
            level: level(),
        },
        e => e,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokenizes_like_babyai() {
        assert_eq!(tokenize("go to the red key").unwrap(), vec![3, 4, 2, 11, 9]);
        assert_eq!(tokenize("Pick up, a BOX").unwrap(), vec![5, 6, 1, 8]);
        assert_eq!(split_words("go to  the ball!"), ["go", "to", "the", "ball"]);
        let err = tokenize("go to the pink key").unwrap_err().to_string();
        assert!(err.contains("\"pink\"") && err.contains("purple"), "{err}");
    }

    #[test]
    fn reads_the_whole_grammar_as_babyai_splits_it() {
        // A comma is no word and "ball," is "ball": re.findall("([a-z]+)", mission.lower()).
        let m = "open the red door, then put a ball next to the key after you go to a box";
        assert_eq!(
            words(&tokenize(m).unwrap()),
            [
                "open", "the", "red", "door", "then", "put", "a", "ball", "next", "to", "the",
                "key", "after", "you", "go", "to", "a", "box"
            ]
        );
        assert_eq!(
            words(&tokenize("pick up the key and go to the grey door").unwrap())[4],
            "and"
        );
        // The paper's words keep their ids: checkpoints trained before the grammar grew read
        // their missions as before.
        assert_eq!(VOCABULARY[PAPER_VOCAB_SIZE - 1], "right");
        assert_eq!(token_id("open"), Some(PAPER_VOCAB_SIZE as u32));
    }

    #[test]
    fn ids_round_trip() {
        for (i, w) in VOCABULARY.iter().enumerate().skip(1) {
            assert_eq!(token_id(w), Some(i as u32));
            assert_eq!(word(i as u32), Some(*w));
        }
        assert_eq!(token_id("<pad>"), None);
    }
}
