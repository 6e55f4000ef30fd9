//! What the user has picked on the step shown, which several panels read: the map laid over
//! the world, the word selected, the cell selected for probing, an object being moved,
//! whether function words' maps fold and whether each map gets its own colour scale.

use crate::env::Pos;
use crate::env::roles::WordRole;

// The rule's own threshold, under the name the panels know it by.
pub use crate::record::fold::FOLD_ABOVE_WORDS;

/// Which map is laid over the world.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Overlay {
    /// None: the plain world with its targets and trail.
    None,
    /// The combined map `M`.
    #[default]
    Combined,
    /// The selected word's map.
    Word,
}

/// The picks shared by the panels.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Selection {
    /// The map laid over the world.
    pub overlay: Overlay,
    /// The word selected (its index in the mission), for the overlay and the weight bars.
    pub word: usize,
    /// The world cell selected for probing.
    pub cell: Option<Pos>,
    /// An object picked up with "move object…": the next click on the world moves it there.
    pub moving_from: Option<Pos>,
    /// Whether the maps of words with no role (function words: "go", "the", "then") fold into
    /// one line; `None` folds them on missions longer than [`FOLD_ABOVE_WORDS`].
    pub fold_function_words: Option<bool>,
    /// Whether each map (and the map laid over the world) is coloured from 0 to its own
    /// largest value instead of the step's shared scale; `None`: on MiniGrid's own
    /// environments only ([`Self::own_scale`]).
    pub own_scale: Option<bool>,
}

impl Selection {
    /// Whether function words' maps fold on a mission of `words` words: the box where it was
    /// set, else the recordings' rule ([`crate::record::fold::folds`]).
    pub fn folds(&self, words: usize) -> bool {
        crate::record::fold::folds(words, self.fold_function_words)
    }

    /// For each of a mission's `words` words, whether its map folds
    /// ([`crate::record::fold::folded_words`], with the box's choice): what the maps, the
    /// weight bars and the episode plot leave out, as a recording does.
    pub fn folded(&self, roles: &[WordRole], words: usize) -> Vec<bool> {
        crate::record::fold::folded_words(roles, words, self.fold_function_words)
    }

    /// Whether maps are drawn on their own scales, on a step of one of MiniGrid's own
    /// environments (`minigrid`) or not. By default they are there: such a mission ("avoid
    /// the lava and get to the green goal square") holds words whose maps peak beside words
    /// whose maps are spread over the view, and on a scale shared with a peak a spread map
    /// reads as one dark colour.
    pub fn own_scale(&self, minigrid: bool) -> bool {
        self.own_scale.unwrap_or(minigrid)
    }

    /// The kind of world picture the overlay asks for: 0 the plain world, 2 with `M` over it,
    /// `3 + i` with word `i`'s map over it (1 is the agent's view).
    pub fn world_kind(&self) -> u8 {
        match self.overlay {
            Overlay::None => 0,
            Overlay::Combined => 2,
            Overlay::Word => 3u8.saturating_add(u8::try_from(self.word).unwrap_or(250)),
        }
    }
}
