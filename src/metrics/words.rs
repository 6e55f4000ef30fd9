//! Grounding word by word (beyond the paper): the object-word and colour-word accuracies of a
//! cell split by the word the mission names. A word class's mean can hide one word that never
//! grounds (two object words of three on their objects give 0.67); this says which.
//! `words.csv` and a `report.md` table; the averages are [`grounding`]'s, over the episodes
//! whose mission names the word.

use std::fmt::Write;

use serde::{Deserialize, Serialize};

use super::grounding::WordKind;
use super::report::Report;
use super::sweep::{EpisodeSummary, GroundingStats, grounding};
use crate::env::mission::Instruction;
use crate::env::object::{Color, ObjectKind};
use crate::env::vocab;
use crate::table::{Record, Table};

/// One word's grounding in a cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WordStats {
    /// Object, colour, door or location word.
    pub kind: WordKind,
    /// The word, as the mission spells it.
    pub word: String,
    /// Episodes whose mission names it.
    pub episodes: u64,
    /// Its map's accuracies over those episodes (per episode, then per seed, then over seeds).
    pub stats: GroundingStats,
}

/// The object and colour words named by the missions of `eps`, each with its map's
/// accuracies over the episodes that name it: object words (key, ball, box), then colours in
/// MiniGrid's order; words no mission names are left out. A mission that does not parse names
/// no word.
pub fn by_word(eps: &[EpisodeSummary]) -> Vec<WordStats> {
    let descs: Vec<_> = eps
        .iter()
        .map(|e| Instruction::parse(&e.mission).ok().map(|i| i.desc))
        .collect();
    let kinds = ObjectKind::PICKABLE.map(|k| (WordKind::Object, k.name(), Some(k), None));
    let colors = Color::ALL.map(|c| (WordKind::Color, c.name(), None, Some(c)));
    let stats = |kind: WordKind, word: &str, named: Vec<EpisodeSummary>| {
        (!named.is_empty()).then(|| WordStats {
            kind,
            word: word.to_owned(),
            episodes: named.len() as u64,
            stats: grounding(&named, kind),
        })
    };
    let mut out: Vec<WordStats> = kinds
        .into_iter()
        .chain(colors)
        .filter_map(|(kind, word, k, c)| {
            let named: Vec<EpisodeSummary> = eps
                .iter()
                .zip(&descs)
                .filter(|(_, d)| {
                    d.is_some_and(|d| (k.is_some() && d.kind == k) || (c.is_some() && d.color == c))
                })
                .map(|(e, _)| e.clone())
                .collect();
            stats(kind, word, named)
        })
        .collect();
    // "door" and the location words, named anywhere in a mission (of one clause or several):
    // their kind's accuracies over the episodes that name them.
    let words: Vec<Vec<&str>> = eps
        .iter()
        .map(|e| vocab::tokenize(&e.mission).map_or_else(|_| Vec::new(), |t| vocab::words(&t)))
        .collect();
    let by_word = [
        (WordKind::Door, "door"),
        (WordKind::Location, "left"),
        (WordKind::Location, "right"),
        (WordKind::Location, "front"),
        (WordKind::Location, "behind"),
    ];
    for (kind, word) in by_word {
        let named: Vec<EpisodeSummary> = eps
            .iter()
            .zip(&words)
            .filter(|(_, ws)| named_as(ws, kind, word))
            .map(|(e, _)| e.clone())
            .collect();
        out.extend(stats(kind, word, named));
    }
    out
}

/// Whether a mission's words name `word` as a word of `kind`: "door" anywhere; a location
/// word only in its phrase ("on your left", "in front of you", "behind you"), not the turn
/// actions' names.
fn named_as(words: &[&str], kind: WordKind, word: &str) -> bool {
    match kind {
        WordKind::Location => words.windows(2).any(|w| match word {
            "left" | "right" => w == ["your", word],
            "front" => w == ["in", "front"],
            _ => w == ["behind", "you"],
        }),
        _ => words.contains(&word),
    }
}

/// Whether a word's `acc` is under half its class's: the class mean hides a word that
/// hardly grounds (red at 0.010 in a colour class of 0.8).
pub fn far_below(word_acc: f64, class_acc: Option<f64>) -> bool {
    class_acc.is_some_and(|c| word_acc < 0.5 * c)
}

/// The fewest evaluated steps behind a figure that `report.md` reads anything into: a word
/// under half its class is flagged ⚠ only over this many ([`flagged`]), and the summary calls
/// a word class grounded or not only over this many. A value from one step (a mission whose
/// object was in view once) is a coin, not a finding.
pub const MIN_EVALUATED_STEPS: u64 = 20;

/// Whether `report.md` flags a word: its `acc` under half its class's ([`far_below`]) over
/// at least [`MIN_EVALUATED_STEPS`] evaluated steps.
pub fn flagged(word_acc: f64, class_acc: Option<f64>, evaluated_steps: u64) -> bool {
    evaluated_steps >= MIN_EVALUATED_STEPS && far_below(word_acc, class_acc)
}

/// A count of evaluated steps as the tables write it: `1 step`, `109 steps`.
pub fn steps_label(evaluated_steps: u64) -> String {
    let unit = if evaluated_steps == 1 {
        "step"
    } else {
        "steps"
    };
    format!("{evaluated_steps} {unit}")
}

/// A table's value with the evaluated steps behind it: `0.000 (1 step)`, `0.948 (109 steps)`.
pub fn with_steps(value: f64, evaluated_steps: u64) -> String {
    format!("{value:.3} ({})", steps_label(evaluated_steps))
}

impl Report {
    /// `words.csv`: one line per attention cell and word named in it.
    pub fn words_csv(&self) -> String {
        let mut t = Table::new(&self.csv_header(
            "checkpoint,size,objects,kind,word,episodes,acc_mean,acc_std,acc_ng_mean,acc_ng_std,evaluated_steps,pointing_mean,pointing_std,mass_mean,mass_std,chance_acc,chance_pointing",
        ));
        for c in &self.cells {
            let Some(a) = &c.accuracy else { continue };
            for w in &a.words {
                t.push(
                    &self.csv_level(
                        Record::new()
                            .field(&c.checkpoint)
                            .field(c.size)
                            .field(c.objects)
                            .field(w.kind.name())
                            .field(&w.word)
                            .field(w.episodes)
                            .mean_std(&w.stats.acc)
                            .mean_std(&w.stats.acc_ng)
                            .field(w.stats.evaluated_steps)
                            .mean_std(&w.stats.pointing)
                            .mean_std(&w.stats.mass)
                            .field(w.stats.chance_cell(0))
                            .field(w.stats.chance_cell(4)),
                        c,
                    ),
                );
            }
        }
        t.finish()
    }

    /// The `report.md` section: one row per attention cell, one column per word (`acc`, mean
    /// over seeds; `–` for a word no mission named).
    pub(super) fn words_table(&self, s: &mut String) {
        if !self.cells.iter().any(|c| c.accuracy.is_some()) {
            return;
        }
        let words: Vec<&str> = ObjectKind::PICKABLE
            .iter()
            .map(|k| k.name())
            .chain(Color::ALL.iter().map(|c| c.name()))
            .collect();
        let _ = writeln!(
            s,
            "\n## Each word's map on its objects (not in the paper)\n"
        );
        let _ = writeln!(
            s,
            "`acc` of each word's map over the episodes whose mission names it (mean over seeds), \
             with the evaluated steps behind it in brackets (`words.csv` has `acc_ng`, the std \
             and the episodes). **⚠** marks a word far below its class (under half the class's \
             `acc`) over at least {MIN_EVALUATED_STEPS} evaluated steps: the class mean hides it. \
             A word seen on fewer steps is not flagged, whatever its value.\n"
        );
        let _ = writeln!(s, "{} {} |", self.key_header(), words.join(" | "));
        let _ = writeln!(s, "{}{}", self.key_rule(), "---|".repeat(words.len()));
        for c in &self.cells {
            let Some(a) = &c.accuracy else { continue };
            let cols: Vec<String> = words
                .iter()
                .map(|w| {
                    let Some(x) = a.words.iter().find(|x| x.word == *w) else {
                        return "–".into();
                    };
                    let class = a.of(x.kind).and_then(|g| g.acc.mean);
                    let steps = x.stats.evaluated_steps;
                    match x.stats.acc.mean {
                        Some(v) if flagged(v, class, steps) => {
                            format!("**{} ⚠**", with_steps(v, steps))
                        }
                        Some(v) => with_steps(v, steps),
                        None => "–".into(),
                    }
                })
                .collect();
            let _ = writeln!(s, "{} {} |", self.cell_key(c), cols.join(" | "));
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::metrics::grounding::Accuracies;

    fn ep(seed: u64, mission: &str, object: f64, color: Option<f64>) -> EpisodeSummary {
        let acc = |a: f64| {
            (
                Accuracies {
                    acc: a,
                    acc_ng: 1.0,
                    ..Accuracies::default()
                },
                3,
            )
        };
        let mut grounding = BTreeMap::from([(WordKind::Object, acc(object))]);
        if let Some(c) = color {
            grounding.insert(WordKind::Color, acc(c));
        }
        EpisodeSummary {
            eval_seed: seed,
            level_seed: seed,
            mission: mission.into(),
            success: true,
            reward: 0.9,
            length: 5,
            grounding,
            failure: None,
            actions: Vec::new(),
            expert: crate::metrics::sweep::EpisodeExpert::default(),
        }
    }

    #[test]
    fn each_word_gets_the_episodes_that_name_it() {
        let eps = [
            ep(0, "go to the red ball", 1.0, Some(0.5)),
            ep(0, "go to the blue key", 0.0, Some(1.0)),
            ep(1, "pick up a red key", 0.5, Some(0.0)),
            ep(1, "go to the ball", 1.0, None),
            ep(1, "not a mission", 1.0, Some(1.0)),
        ];
        let w = by_word(&eps);
        let names: Vec<(&str, u64)> = w.iter().map(|x| (x.word.as_str(), x.episodes)).collect();
        // Object words first, then colours in MiniGrid order; unnamed words left out.
        assert_eq!(names, [("key", 2), ("ball", 2), ("red", 2), ("blue", 1)]);
        let acc = |word: &str| w.iter().find(|x| x.word == word).unwrap().stats.acc;
        // key: seed 0 → 0.0, seed 1 → 0.5: mean 0.25 ± 0.25 over seeds.
        assert_eq!(acc("key").mean, Some(0.25));
        assert_eq!(acc("key").std, Some(0.25));
        assert_eq!(acc("ball").mean, Some(1.0));
        // Colour words read the colour map, not the object map.
        assert_eq!(acc("red").mean, Some(0.25));
        assert_eq!(acc("blue").mean, Some(1.0));
        assert_eq!(w[0].kind, WordKind::Object);
        assert_eq!(w[2].kind, WordKind::Color);
    }

    /// "door" and the location words get rows of their own kinds, from missions of one clause
    /// or several; "left" as a turn is not a location word.
    #[test]
    fn door_and_location_words_get_their_rows() {
        let with = |mut e: EpisodeSummary, kind: WordKind, a: f64| {
            e.grounding.insert(
                kind,
                (
                    Accuracies {
                        acc: a,
                        ..Accuracies::default()
                    },
                    2,
                ),
            );
            e
        };
        let eps = [
            with(
                ep(0, "open the red door", 1.0, Some(1.0)),
                WordKind::Door,
                0.5,
            ),
            with(
                ep(
                    0,
                    "pick up the ball on your left, then open a door",
                    1.0,
                    None,
                ),
                WordKind::Door,
                1.0,
            ),
            with(
                ep(0, "pick up the ball behind you", 1.0, None),
                WordKind::Location,
                0.25,
            ),
        ];
        let w = by_word(&eps);
        let row = |word: &str| w.iter().find(|x| x.word == word);
        let door = row("door").unwrap();
        assert_eq!((door.kind, door.episodes), (WordKind::Door, 2));
        assert_eq!(door.stats.acc.mean, Some(0.75));
        assert_eq!(row("left").unwrap().episodes, 1);
        let behind = row("behind").unwrap();
        assert_eq!((behind.kind, behind.episodes), (WordKind::Location, 1));
        assert_eq!(behind.stats.acc.mean, Some(0.25));
        assert!(row("right").is_none() && row("front").is_none());
    }

    #[test]
    fn a_word_under_half_its_class_is_flagged() {
        assert!(far_below(0.010, Some(0.80)));
        assert!(!far_below(0.45, Some(0.80)));
        assert!(!far_below(0.0, None));
    }

    /// A word seen on one step (GoToSeqS5R2's "blue" at 0.000 beside a colour class of 0.85)
    /// is no finding: it is shown with its count and not flagged; over enough steps it is.
    #[test]
    fn a_word_seen_on_too_few_steps_is_not_flagged() {
        assert!(!flagged(0.0, Some(0.85), 1));
        assert!(!flagged(0.0, Some(0.85), MIN_EVALUATED_STEPS - 1));
        assert!(flagged(0.0, Some(0.85), MIN_EVALUATED_STEPS));
        assert!(!flagged(0.6, Some(0.85), 1000));
        assert_eq!(with_steps(0.0, 1), "0.000 (1 step)");
        assert_eq!(with_steps(0.9482, 109), "0.948 (109 steps)");
    }

    /// The words table of `report.md`: every value with its count, ⚠ only over enough steps.
    #[test]
    fn the_words_table_shows_counts_and_flags_only_well_measured_words() {
        use crate::metrics::report::{Cell, CellAccuracy, Report};
        use crate::metrics::sweep::{MeanStd, Performance};
        let m = |v: f64| MeanStd {
            mean: Some(v),
            std: Some(0.0),
        };
        let stats = |acc: f64, steps: u64| GroundingStats {
            acc: m(acc),
            evaluated_steps: steps,
            ..grounding(&[], WordKind::Color)
        };
        let word = |kind: WordKind, word: &str, acc: f64, steps: u64| WordStats {
            kind,
            word: word.into(),
            episodes: 1,
            stats: stats(acc, steps),
        };
        let accuracy = CellAccuracy {
            object: stats(1.0, 100),
            color: stats(0.85, 100),
            combined: stats(0.6, 100),
            words: vec![
                word(WordKind::Object, "key", 1.0, 40),
                word(WordKind::Color, "red", 0.0, 25),
                word(WordKind::Color, "blue", 0.0, 1),
                word(WordKind::Color, "grey", 0.8, 30),
            ],
            door: None,
            location: None,
            goal: None,
            lava: None,
            opening: None,
        };
        let perf = Performance {
            reward: m(1.0),
            success: m(1.0),
            length: m(5.0),
            reward_given_success: m(1.0),
        };
        let report = Report::of_cells(
            vec![Cell::new("ck", "attention", 8, 4, 4, &perf, Some(accuracy))],
            4,
        );
        let mut s = String::new();
        report.words_table(&mut s);
        let row = s
            .lines()
            .find(|l| l.starts_with("| ck |"))
            .unwrap_or_else(|| panic!("{s}"));
        assert_eq!(
            row,
            "| ck | 8 | 4 | 1.000 (40 steps) | – | – | **0.000 (25 steps) ⚠** | – | 0.000 (1 step) | – | – | 0.800 (30 steps) |"
        );
    }
}
