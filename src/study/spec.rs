//! A study's spec (`study.toml`): seeds, frames, and named recipes and level sets, each given
//! as the flags of the command it configures (docs/studies.md#the-spec). This module reads its
//! structure and names the grid's runs ([`StudySpec::cells`]); the command line's parser turns
//! each run's flags into its typed steps once, when the study is planned.
//!
//! ```toml
//! seeds = [1, 2, 3]
//! frames = 500000
//! eval = ["--first-seed", "1500", "--seeds", "3", "--episodes", "100"]
//! faithfulness = ["--episodes", "20"]          # optional
//!
//! [recipes]                                     # named sets of `train` flags
//! ppo = ["--model", "attention"]
//!
//! [levels]                                      # named level sets
//! paper = "paper"                               # the paper's level
//! goto = "BabyAI-GoToLocal-v0"                  # a registered id
//! mix = { train = ["--levels", "BabyAI-GoToLocal-v0,BabyAI-PickupLoc-v0:2"] }
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use super::{StudyError, one_line, shown};

/// The longest name of a recipe or a level set: a run's directory, `RECIPE-LEVELS-sSEED`,
/// stays within the 255 bytes a file name may have.
const NAME_MAX: usize = 100;

/// The level set that names the paper's level.
pub const PAPER: &str = "paper";

/// `study.toml`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudySpec {
    /// Training seeds: every recipe on every level set from each.
    pub seeds: Vec<u64>,
    /// Frames each run trains for.
    pub frames: u64,
    /// Flags of the evaluation that follows each training (its checkpoint, output directory
    /// and levels are the run's).
    #[serde(default)]
    pub eval: Vec<String>,
    /// Flags of a faithfulness run after the evaluation; absent: none.
    #[serde(default)]
    pub faithfulness: Option<Vec<String>>,
    /// Named sets of training flags.
    pub recipes: BTreeMap<String, Vec<String>>,
    /// Named level sets.
    pub levels: BTreeMap<String, LevelSet>,
}

/// A level set: [`PAPER`], a registered id, or the flags of the training (and optionally of
/// the evaluation) for its levels.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum LevelSet {
    /// [`PAPER`] or a registered id.
    Named(String),
    /// Explicit flags.
    Flags {
        /// The training's flags for the levels.
        train: Vec<String>,
        /// The evaluation's (default: the training's levels, their weights dropped; the
        /// paper's 8×8 room with 4 objects where the training names none).
        #[serde(default)]
        eval: Option<Vec<String>>,
    },
}

/// One run of the grid: a recipe on a level set from a seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell<'a> {
    /// `RECIPE-LEVELS-sSEED`: the run's name and directory under `runs/`.
    pub name: String,
    /// The recipe's name.
    pub recipe: &'a str,
    /// The recipe's training flags.
    pub flags: &'a [String],
    /// The level set's name.
    pub levels: &'a str,
    /// The level set.
    pub set: &'a LevelSet,
    /// The training seed.
    pub seed: u64,
}

impl StudySpec {
    /// Parses `study.toml`'s text; an error names `file` and the field.
    pub fn parse(text: &str, file: &Path) -> Result<Self, StudyError> {
        let spec: Self = toml::from_str(text).map_err(|e| StudyError::Spec {
            file: file.to_path_buf(),
            what: toml_error(&e, text),
        })?;
        spec.check(file)?;
        Ok(spec)
    }

    fn check(&self, file: &Path) -> Result<(), StudyError> {
        let bad = |what: String| {
            Err(StudyError::Spec {
                file: file.to_path_buf(),
                what,
            })
        };
        if self.seeds.is_empty() || self.recipes.is_empty() || self.levels.is_empty() {
            return bad("seeds, recipes and levels must each name at least one".into());
        }
        if self.frames == 0 {
            return bad("frames must be at least 1".into());
        }
        let mut seen = std::collections::BTreeSet::new();
        for s in &self.seeds {
            if !seen.insert(s) {
                return bad(format!("seed {s} is listed twice"));
            }
        }
        for name in self.recipes.keys().chain(self.levels.keys()) {
            if name.is_empty()
                || !name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.')
            {
                return bad(format!(
                    "name {}: recipes and level sets are named with letters, digits, '_' and '.' (they name run directories, joined by '-')",
                    shown(name)
                ));
            }
            if name.len() > NAME_MAX {
                return bad(format!(
                    "name {}: recipes and level sets are named in at most {NAME_MAX} characters (they name run directories)",
                    shown(name)
                ));
            }
        }
        Ok(())
    }

    /// Every run of the grid, in the order the engines take them: seed by seed, then recipe by
    /// recipe and level set by level set (in name order).
    pub fn cells(&self) -> Vec<Cell<'_>> {
        let mut cells = Vec::new();
        for &seed in &self.seeds {
            for (recipe, flags) in &self.recipes {
                for (levels, set) in &self.levels {
                    cells.push(Cell {
                        name: format!("{recipe}-{levels}-s{seed}"),
                        recipe,
                        flags,
                        levels,
                        set,
                        seed,
                    });
                }
            }
        }
        cells
    }
}

/// TOML's error as one line: the line it is on and TOML's message, not the line itself (which
/// may be a whole file long), escaped and cut ([`one_line`]).
fn toml_error(e: &toml::de::Error, text: &str) -> String {
    match e.span() {
        Some(span) => {
            let before = text.get(..span.start).unwrap_or(text);
            let line = before.matches('\n').count() + 1;
            format!("line {line}: {}", one_line(e.message()))
        }
        None => one_line(&e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPEC: &str = include_str!("test_spec.toml");

    #[test]
    fn a_spec_names_one_run_per_seed_recipe_and_level_set() {
        let spec = StudySpec::parse(SPEC, Path::new("study.toml")).unwrap();
        let cells = spec.cells();
        assert_eq!(cells.len(), 8);
        let names: Vec<&str> = cells.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names[..4],
            ["ent-mix-s1", "ent-paper-s1", "ppo-mix-s1", "ppo-paper-s1"]
        );
        let last = &cells[7];
        assert_eq!((last.recipe, last.levels, last.seed), ("ppo", "paper", 2));
        assert_eq!(last.set, &LevelSet::Named(PAPER.into()));
        assert_eq!(cells[4].flags.len(), 6);
    }

    #[test]
    fn bad_specs_are_refused_naming_the_file_and_field() {
        for (text, says) in [
            (SPEC.replace("seeds = [1, 2]", "seeds = []"), "at least one"),
            (SPEC.replace("[1, 2]", "[1, 1]"), "seed 1 is listed twice"),
            (
                SPEC.replace("frames = 1000", "frames = 1000\nframs = 2"),
                "frams",
            ),
            (SPEC.replace("frames = 1000", "frames = 0"), "at least 1"),
            (SPEC.replace("ppo =", "\"p-o\" ="), "\"p-o\""),
            ("seeds = [1".to_owned(), "study.toml"),
        ] {
            let e = StudySpec::parse(&text, Path::new("study.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(says) && e.contains("study.toml"), "{says}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
