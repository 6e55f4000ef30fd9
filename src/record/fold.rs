//! Which of a mission's words fold out of the maps: one rule for the debugger and the Rerun
//! recordings, so that a long mission shows the same maps in both. A mission longer than
//! BabyAI's local ones folds the words with no role in the grammar ("go", "the", "then", "of"):
//! `BossLevel`'s sixteen such maps pushed the content words' out of sight, while a short
//! mission's few maps are all shown, where a reader expects every one of them.

use crate::env::roles::{WordClass, WordRole};

/// Missions longer than this (BabyAI's local ones have at most 9 words) fold their function
/// words' maps by default.
pub const FOLD_ABOVE_WORDS: usize = 9;

/// Whether a mission of `words` words folds its function words: as `choice` says where the
/// user chose (the debugger's "fold function words" box), else when it is longer than
/// [`FOLD_ABOVE_WORDS`].
pub fn folds(words: usize, choice: Option<bool>) -> bool {
    choice.unwrap_or(words > FOLD_ABOVE_WORDS)
}

/// For each of a mission's `words` words (its attention trace's, in order), whether its map
/// folds: the words of class [`WordClass::Other`], where [`folds`] says the mission folds.
/// `roles` are the mission's ([`crate::env::roles::roles_of`]); where they do not line up with
/// the words (a mission the policy split otherwise) nothing folds, since which word has which
/// role is then not known.
pub fn folded_words(roles: &[WordRole], words: usize, choice: Option<bool>) -> Vec<bool> {
    if roles.len() != words || !folds(words, choice) {
        return vec![false; words];
    }
    roles.iter().map(|r| r.class == WordClass::Other).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::parse_mission;
    use crate::env::roles::word_roles;

    #[test]
    fn a_long_mission_folds_its_function_words_and_a_short_one_nothing() {
        let long =
            word_roles(&parse_mission("go to the red ball, then pick up a blue key").unwrap());
        assert_eq!(long.len(), 11);
        let folded = folded_words(&long, 11, None);
        // go to the [red ball] then pick up a [blue key]
        let want = [
            true, true, true, false, false, true, true, true, true, false, false,
        ];
        assert_eq!(folded, want);
        // The debugger's box unticked shows them all; ticked, a short mission folds too.
        assert_eq!(folded_words(&long, 11, Some(false)), vec![false; 11]);
        let short = word_roles(&parse_mission("go to the red ball").unwrap());
        assert_eq!(folded_words(&short, 5, None), vec![false; 5]);
        assert_eq!(
            folded_words(&short, 5, Some(true)),
            [true, true, true, false, false]
        );
        // Roles that do not line up with the words fold nothing.
        assert_eq!(folded_words(&long, 12, None), vec![false; 12]);
    }
}
