//! The summary `report.md` opens with: success, what grounds beside chance and what does not,
//! the main failure classes and the worst level, in at most [`MAX_LINES`] lines. Every figure
//! in it is one the tables below give — a cell's success, a word kind's pointing game, `acc`
//! and their chance, the failure counts — or a range or a count of them: none is computed
//! another way. The one sum is a checkpoint's overall success, its cells' success weighted by
//! their episodes (every seed of a cell has as many episodes, so this is the share of all its
//! episodes that succeeded).

use std::cmp::{Ordering, Reverse};
use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::{Cell, Report};
use crate::metrics::failure::FailureClass;
use crate::metrics::grounding::WordKind;
use crate::metrics::sweep::GroundingStats;
use crate::metrics::words::{MIN_EVALUATED_STEPS, steps_label};

/// How far a word kind's pointing game must be above its chance (a uniform map's on the same
/// steps) for the summary to say it grounds: the map's largest cell is on a related object on a
/// quarter of the evaluated steps more than a uniform map's would be. The door word's 0.04–0.10
/// against a chance of 0.03–0.04 (docs/evaluation.md) does not ground; the object words'
/// 0.85–1.00 against 0.02–0.05 do.
pub const GROUNDS_ABOVE_CHANCE: f64 = 0.25;

/// The most lines the summary has.
pub const MAX_LINES: usize = 8;

/// The most failure classes the summary names.
const TOP_CLASSES: usize = 3;

/// Chance's figures as [`GroundingStats::chance_mean`] indexes them: `acc`, the pointing game.
const CHANCE_ACC: usize = 0;
const CHANCE_POINTING: usize = 4;

/// What one cell's figures say of a word kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reading {
    /// Its pointing game is at least [`GROUNDS_ABOVE_CHANCE`] above chance.
    Grounds,
    /// It is not.
    DoesNot,
    /// Fewer than [`MIN_EVALUATED_STEPS`] evaluated steps: nothing to tell.
    TooFew,
}

/// What `g` says of its word kind; `None` where no step was evaluated (a level whose missions
/// hold no such word).
fn reading(g: &GroundingStats) -> Option<Reading> {
    if g.evaluated_steps == 0 {
        return None;
    }
    match (g.pointing.mean, g.chance_mean(CHANCE_POINTING)) {
        (Some(p), Some(c)) if g.evaluated_steps >= MIN_EVALUATED_STEPS => {
            Some(if p - c >= GROUNDS_ABOVE_CHANCE {
                Reading::Grounds
            } else {
                Reading::DoesNot
            })
        }
        _ => Some(Reading::TooFew),
    }
}

/// A word kind as the summary names it.
fn kind_phrase(kind: WordKind) -> &'static str {
    match kind {
        WordKind::Object => "object words",
        WordKind::Color => "colour words",
        WordKind::Combined => "`M` on the targets",
        WordKind::Door => "\"door\"",
        WordKind::Location => "location words",
        WordKind::Goal => "\"goal\"",
        WordKind::Lava => "\"lava\"",
        WordKind::Opening => "\"opening\"",
    }
}

/// The values' range with three decimals, as the tables write them: `0.850–1.000`, one value
/// where both ends read alike, `–` for none.
fn range(values: &[f64]) -> String {
    if values.is_empty() {
        return "–".into();
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (a, b) = (format!("{lo:.3}"), format!("{hi:.3}"));
    if a == b { a } else { format!("{a}–{b}") }
}

/// The [`range`] of a figure `f` reads off each of `stats` (those it has).
fn range_of(stats: &[&GroundingStats], f: &dyn Fn(&GroundingStats) -> Option<f64>) -> String {
    range(&stats.iter().filter_map(|g| f(g)).collect::<Vec<f64>>())
}

impl Report {
    /// The summary section: a heading and at most [`MAX_LINES`] lines.
    pub(super) fn summary(&self, s: &mut String) {
        let _ = writeln!(s, "## Summary\n");
        for line in self.summary_lines() {
            let _ = writeln!(s, "- {line}");
        }
    }

    /// The summary's lines: success, grounding (what grounds, what does not, what was seen
    /// too little to tell), the main failure classes, the worst level.
    pub(super) fn summary_lines(&self) -> Vec<String> {
        let mut lines = vec![self.success_line()];
        lines.extend(self.grounding_lines());
        lines.push(self.failures_line());
        lines.extend(self.worst_line());
        lines.truncate(MAX_LINES);
        lines
    }

    /// The cell with the lowest success (the first of equals, in table order).
    fn worst_cell(&self) -> Option<&Cell> {
        self.cells
            .iter()
            .filter(|c| c.success.mean.is_some())
            .min_by(|a, b| {
                a.success
                    .mean
                    .partial_cmp(&b.success.mean)
                    .unwrap_or(Ordering::Equal)
            })
    }

    /// Each checkpoint's success over all its episodes, and the lowest cell's (as the
    /// performance table gives it).
    fn success_line(&self) -> String {
        let mut names: Vec<&str> = Vec::new();
        for c in &self.cells {
            if !names.contains(&c.checkpoint.as_str()) {
                names.push(&c.checkpoint);
            }
        }
        let per: Vec<String> = names
            .iter()
            .filter_map(|name| {
                let cells: Vec<&Cell> = self
                    .cells
                    .iter()
                    .filter(|c| c.checkpoint == *name && c.success.mean.is_some())
                    .collect();
                let episodes: u64 = cells.iter().map(|c| c.episodes).sum();
                let succeeded: f64 = cells
                    .iter()
                    .filter_map(|c| c.success.mean.map(|m| m * c.episodes as f64))
                    .sum();
                (episodes > 0).then(|| {
                    format!(
                        "`{name}` {:.3} of its {episodes} episodes",
                        succeeded / episodes as f64
                    )
                })
            })
            .collect();
        let mut line = format!(
            "**Success**: {}",
            if per.is_empty() {
                "nothing measured".to_owned()
            } else {
                per.join(", ")
            }
        );
        if self.cells.len() > 1
            && let Some(c) = self.worst_cell()
        {
            let _ = write!(
                line,
                "; lowest: {} of `{}` at {}",
                c.label(),
                c.checkpoint,
                self.over_seeds(&c.success)
            );
        }
        line.push('.');
        line
    }

    /// A word kind over the report's attention cells: how it reads (it grounds where it
    /// grounds in every cell with enough steps) and its figures there.
    fn kind_item(&self, kind: WordKind) -> Option<(Reading, String)> {
        let read: Vec<(&GroundingStats, Reading)> = self
            .cells
            .iter()
            .filter_map(|c| c.accuracy.as_ref()?.of(kind))
            .filter_map(|g| Some((g, reading(g)?)))
            .collect();
        if read.is_empty() {
            return None;
        }
        let phrase = kind_phrase(kind);
        let enough: Vec<&GroundingStats> = read
            .iter()
            .filter(|(_, r)| *r != Reading::TooFew)
            .map(|(g, _)| *g)
            .collect();
        if enough.is_empty() {
            let steps: u64 = read.iter().map(|(g, _)| g.evaluated_steps).sum();
            return Some((
                Reading::TooFew,
                format!("{phrase} ({})", steps_label(steps)),
            ));
        }
        let n = enough.len();
        let k = read.iter().filter(|(_, r)| *r == Reading::Grounds).count();
        let cells = if n == 1 {
            String::new()
        } else if k == 0 || k == n {
            format!(" over {n} cells")
        } else {
            format!(" (grounds in {k} of {n} cells)")
        };
        let steps: u64 = enough.iter().map(|g| g.evaluated_steps).sum();
        let text = format!(
            "{phrase}{cells}: pointing {} (chance {}), acc {} (chance {}); {}",
            range_of(&enough, &|g| g.pointing.mean),
            range_of(&enough, &|g| g.chance_mean(CHANCE_POINTING)),
            range_of(&enough, &|g| g.acc.mean),
            range_of(&enough, &|g| g.chance_mean(CHANCE_ACC)),
            steps_label(steps)
        );
        Some((
            if k == n {
                Reading::Grounds
            } else {
                Reading::DoesNot
            },
            text,
        ))
    }

    /// What grounds beside chance, what does not, what was seen too little to tell.
    fn grounding_lines(&self) -> Vec<String> {
        if !self.cells.iter().any(|c| c.accuracy.is_some()) {
            return vec!["**Grounding**: not measured; no checkpoint here has maps.".to_owned()];
        }
        let (mut grounds, mut not, mut few) = (Vec::new(), Vec::new(), Vec::new());
        for kind in WordKind::ALL {
            match self.kind_item(kind) {
                Some((Reading::Grounds, t)) => grounds.push(t),
                Some((Reading::DoesNot, t)) => not.push(t),
                Some((Reading::TooFew, t)) => few.push(t),
                None => {}
            }
        }
        let mut lines = Vec::new();
        if !grounds.is_empty() {
            lines.push(format!(
                "**Grounds beside chance** (pointing game at least {GROUNDS_ABOVE_CHANCE} above a uniform map's): {}.",
                grounds.join("; ")
            ));
        }
        if !not.is_empty() {
            lines.push(format!(
                "**Does not ground** (pointing game less than {GROUNDS_ABOVE_CHANCE} above chance): {}.",
                not.join("; ")
            ));
        }
        if !few.is_empty() {
            lines.push(format!(
                "**Too few evaluated steps to tell** (under {MIN_EVALUATED_STEPS}): {}.",
                few.join("; ")
            ));
        }
        lines
    }

    /// The failure classes with the most failed episodes over all cells.
    fn failures_line(&self) -> String {
        let mut counts: BTreeMap<FailureClass, u64> = BTreeMap::new();
        for c in &self.cells {
            for (k, n) in &c.failure_classes {
                *counts.entry(*k).or_default() += n;
            }
        }
        let failed: u64 = counts.values().sum();
        let episodes: u64 = self.cells.iter().map(|c| c.episodes).sum();
        if failed == 0 {
            return format!("**Failures**: none of the {episodes} episodes failed.");
        }
        let mut top: Vec<(FailureClass, u64)> =
            counts.into_iter().filter(|&(_, n)| n > 0).collect();
        // Stable: classes with as many failures keep their declared order.
        top.sort_by_key(|&(_, n)| Reverse(n));
        top.truncate(TOP_CLASSES);
        let named: Vec<String> = top
            .iter()
            .map(|(k, n)| format!("`{}` {n}", k.name()))
            .collect();
        format!(
            "**Main failure classes**: {} ({failed} failed of {episodes} episodes).",
            named.join(", ")
        )
    }

    /// The cell with the lowest success: its failures, its most frequent class and where its
    /// `M` points.
    fn worst_line(&self) -> Option<String> {
        let c = self.worst_cell()?;
        let what = if c.level.is_some() {
            "Worst level"
        } else {
            "Worst cell"
        };
        let failed: u64 = c.failure_classes.values().sum();
        if failed == 0 {
            return Some(format!("**{what}**: none; no episode failed."));
        }
        let most = c
            .failure_classes
            .iter()
            .filter(|&(_, &n)| n > 0)
            .min_by_key(|&(_, &n)| Reverse(n))
            .map_or_else(String::new, |(k, n)| {
                format!(", most as `{}` ({n})", k.name())
            });
        let m = c
            .accuracy
            .as_ref()
            .filter(|a| a.combined.pointing.mean.is_some())
            .map_or_else(String::new, |a| {
                format!(
                    "; its `M` points at the targets on {} of the evaluated steps (chance {})",
                    self.over_seeds(&a.combined.pointing),
                    a.combined
                        .chance_mean(CHANCE_POINTING)
                        .map_or_else(|| "–".to_owned(), |v| format!("{v:.3}"))
                )
            });
        Some(format!(
            "**{what}**: {} of `{}`: success {}, {failed} of its {} episodes failed{most}{m}.",
            c.label(),
            c.checkpoint,
            self.over_seeds(&c.success),
            c.episodes
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::super::CellAccuracy;
    use super::*;
    use crate::metrics::sweep::{MeanStd, Performance, grounding};

    fn m(v: f64) -> MeanStd {
        MeanStd {
            mean: Some(v),
            std: Some(0.0),
        }
    }

    /// Grounding stats with a pointing game, its chance, an `acc` and a count.
    fn stats(pointing: f64, chance: f64, acc: f64, steps: u64) -> GroundingStats {
        let mut g = grounding(&[], WordKind::Object);
        g.pointing = m(pointing);
        g.acc = m(acc);
        g.chance = (0..6)
            .map(|i| m(if i == 4 { chance } else { 0.0 }))
            .collect();
        g.evaluated_steps = steps;
        g
    }

    fn cell(level: &str, success: f64, episodes: u64, failures: &[(FailureClass, u64)]) -> Cell {
        let perf = Performance {
            reward: m(success),
            success: m(success),
            length: m(10.0),
            reward_given_success: m(1.0),
        };
        let accuracy = CellAccuracy {
            object: stats(0.96, 0.02, 0.9, 500),
            color: stats(0.9, 0.03, 0.8, 400),
            combined: stats(0.86, 0.02, 0.6, 300),
            words: Vec::new(),
            door: Some(stats(0.08, 0.04, 0.05, 200)),
            location: Some(stats(0.0, 0.03, 0.0, 1)),
            goal: None,
            lava: None,
            opening: None,
        };
        Cell::new("ck", "attention", 8, 0, episodes, &perf, Some(accuracy))
            .with_level(Some(level.to_owned()))
            .with_failure_classes(failures.iter().copied().collect::<BTreeMap<_, _>>())
    }

    fn report(cells: Vec<Cell>) -> Report {
        Report::of_cells(cells, 20)
    }

    #[test]
    fn the_summary_says_what_grounds_what_fails_and_where() {
        let r = report(vec![
            cell("BabyAI-GoToDoor-v0", 1.0, 20, &[]),
            cell(
                "BabyAI-GoToSeqS5R2-v0",
                0.85,
                20,
                &[
                    (FailureClass::Grounding, 2),
                    (FailureClass::TargetNeverVisible, 1),
                ],
            ),
        ]);
        let lines = r.summary_lines();
        assert!(lines.len() <= MAX_LINES, "{lines:#?}");
        let all = lines.join("\n");
        // Success: 34 of 40 episodes, the lowest cell as its table gives it.
        assert!(
            lines[0].contains("`ck` 0.925 of its 40 episodes")
                && lines[0].contains("lowest: BabyAI-GoToSeqS5R2-v0 of `ck` at 0.850"),
            "{all}"
        );
        // What grounds beside chance and what does not, with the figures and their chance.
        let grounds = lines.iter().find(|l| l.starts_with("**Grounds")).unwrap();
        assert!(
            grounds.contains(
                "object words over 2 cells: pointing 0.960 (chance 0.020), acc 0.900 (chance 0.000); 1000 steps"
            ),
            "{all}"
        );
        assert!(
            grounds.contains("colour words") && grounds.contains("`M`"),
            "{all}"
        );
        let not = lines.iter().find(|l| l.starts_with("**Does not")).unwrap();
        assert!(
            not.contains("\"door\" over 2 cells: pointing 0.080 (chance 0.040)"),
            "{all}"
        );
        // A kind seen on one step per cell is not read at all.
        let few = lines.iter().find(|l| l.starts_with("**Too few")).unwrap();
        assert!(few.contains("location words (2 steps)"), "{all}");
        assert!(!grounds.contains("location") && !not.contains("location"));
        // The failure classes, most first, with their counts.
        assert!(
            all.contains("**Main failure classes**: `grounding` 2, `target_never_visible` 1 (3 failed of 40 episodes)."),
            "{all}"
        );
        assert!(
            all.contains(
                "**Worst level**: BabyAI-GoToSeqS5R2-v0 of `ck`: success 0.850, 3 of its 20 episodes failed, most as `grounding` (2)"
            ),
            "{all}"
        );
    }

    #[test]
    fn a_sweep_without_failures_or_maps_says_so() {
        let mut c = cell("BabyAI-GoToDoor-v0", 1.0, 20, &[]);
        c.accuracy = None;
        let lines = report(vec![c]).summary_lines();
        let all = lines.join("\n");
        assert!(
            all.contains("not measured; no checkpoint here has maps"),
            "{all}"
        );
        assert!(all.contains("none of the 20 episodes failed"), "{all}");
        assert!(all.contains("**Worst level**: none"), "{all}");
        assert!(
            !lines[0].contains("lowest"),
            "one cell has no lowest: {all}"
        );
    }

    /// The summary's figures are the tables': a kind that grounds in one cell and not another
    /// is not said to ground.
    #[test]
    fn a_kind_that_grounds_in_some_cells_only_does_not_ground() {
        let mut weak = cell("BabyAI-PickupLoc-v0", 1.0, 20, &[]);
        if let Some(a) = weak.accuracy.as_mut() {
            a.color = stats(0.1, 0.03, 0.05, 300);
        }
        let r = report(vec![cell("BabyAI-GoToLocal-v0", 1.0, 20, &[]), weak]);
        let lines = r.summary_lines();
        let not = lines.iter().find(|l| l.starts_with("**Does not")).unwrap();
        assert!(
            not.contains("colour words (grounds in 1 of 2 cells): pointing 0.100–0.900"),
            "{not}"
        );
        assert_eq!(range(&[0.5]), "0.500");
        assert_eq!(range(&[]), "–");
    }
}
