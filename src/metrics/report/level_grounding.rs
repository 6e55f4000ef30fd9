//! Grounding per BabyAI level (`eval --levels`): a `report.md` table of each word kind's
//! pointing game beside its chance and its count, and `fig_grounding_levels.png`, the same
//! figures as a row of bars per level with chance marked. The paper's figures 7 and 8 plot its
//! own level's cells only; a sweep over BabyAI levels had no grounding figure before this.

use std::fmt::Write as _;
use std::path::Path;

use super::bars::Bar;
use super::{Cell, Report};
use crate::metrics::error::MetricsError;
use crate::metrics::grounding::WordKind;
use crate::metrics::sweep::GroundingStats;
use crate::metrics::words::steps_label;

/// The per-level grounding figure.
pub const FIG_GROUNDING_LEVELS: &str = "fig_grounding_levels.png";

/// The chance of a word kind's pointing game: a uniform map's on the same steps.
const POINTING_CHANCE: usize = 4;

/// A word kind's pointing game as the table gives it: `1.000 (chance 0.022; 1730 steps)`, the
/// spread over seeds where there are several; `–` where nothing was measured.
fn pointing_cell(report: &Report, g: &GroundingStats) -> String {
    if g.pointing.mean.is_none() {
        return "–".into();
    }
    let chance = g
        .chance_mean(POINTING_CHANCE)
        .map_or_else(|| "–".to_owned(), |v| format!("{v:.3}"));
    format!(
        "{} (chance {chance}; {})",
        report.over_seeds(&g.pointing),
        steps_label(g.evaluated_steps)
    )
}

/// The value axis of [`FIG_GROUNDING_LEVELS`]: a spread over seeds is named only where there
/// are several seeds.
pub(crate) fn pointing_axis(seeds: u64) -> &'static str {
    if seeds >= 2 {
        "pointing game (mean over seeds; line: ± std over seeds; black tick: chance)"
    } else {
        "pointing game (one seed; black tick: chance, a uniform map's)"
    }
}

impl Report {
    /// The attention cells on BabyAI levels: what the per-level grounding table and figure
    /// show.
    fn grounded_level_cells(&self) -> impl Iterator<Item = &Cell> {
        self.level_cells().filter(|c| c.accuracy.is_some())
    }

    /// Whether the report has [`FIG_GROUNDING_LEVELS`]: some attention cell on a BabyAI level.
    pub(crate) fn has_grounding_levels(&self) -> bool {
        self.grounded_level_cells().next().is_some()
    }

    /// The `report.md` section: one row per attention cell on a BabyAI level, one column per
    /// word kind (its pointing game, chance and evaluated steps), the figure under it. Empty
    /// without such cells.
    pub(super) fn grounding_levels_table(&self, s: &mut String) {
        if !self.has_grounding_levels() {
            return;
        }
        let _ = writeln!(s, "\n## Pointing game per level (not in the paper)\n");
        let _ = writeln!(
            s,
            "Each word kind's pointing game (the `pointing` column of the tables above: the map's \
             largest cell on a related object) beside a uniform map's on the same steps, with the \
             evaluated steps behind it; – where the level's missions hold no such word.\n"
        );
        let names: Vec<&str> = WordKind::ALL.iter().map(|k| k.name()).collect();
        let _ = writeln!(s, "| checkpoint | level | {} |", names.join(" | "));
        let _ = writeln!(s, "|---|---|{}", "---|".repeat(names.len()));
        for c in self.grounded_level_cells() {
            let cols: Vec<String> = WordKind::ALL
                .iter()
                .map(|&k| {
                    c.accuracy
                        .as_ref()
                        .and_then(|a| a.of(k))
                        .map_or_else(|| "–".to_owned(), |g| pointing_cell(self, g))
                })
                .collect();
            let _ = writeln!(
                s,
                "| {} | {} | {} |",
                c.checkpoint,
                c.label(),
                cols.join(" | ")
            );
        }
        let _ = writeln!(
            s,
            "\n![Pointing game per word kind and level, chance marked]({FIG_GROUNDING_LEVELS})"
        );
    }

    /// The bars of [`FIG_GROUNDING_LEVELS`] for a cell: each word kind's pointing game with its
    /// chance, named by the kind (and the checkpoint, when several have maps).
    fn pointing_bars(&self, c: &Cell) -> Vec<Bar> {
        let Some(a) = &c.accuracy else {
            return Vec::new();
        };
        let mut with_maps: Vec<&str> = self
            .grounded_level_cells()
            .map(|k| k.checkpoint.as_str())
            .collect();
        with_maps.sort_unstable();
        with_maps.dedup();
        a.by_kind()
            .into_iter()
            .filter(|(_, g)| g.pointing.mean.is_some())
            .map(|(kind, g)| {
                let name = if with_maps.len() > 1 {
                    format!("{} {}", c.checkpoint, kind.name())
                } else {
                    kind.name().to_owned()
                };
                (name, g.pointing, g.chance_mean(POINTING_CHANCE))
            })
            .collect()
    }

    /// Draws [`FIG_GROUNDING_LEVELS`] at `path`: a row per level, a bar per word kind (its
    /// pointing game), a black tick at its chance.
    pub(super) fn grounding_levels_figure(&self, path: &Path) -> Result<(), MetricsError> {
        self.levels_bars_marked(
            path,
            "Pointing game per word kind and level",
            pointing_axis(self.seeds),
            &|c: &Cell| self.pointing_bars(c),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pointing_axis_names_a_spread_only_over_several_seeds() {
        assert!(!pointing_axis(1).contains('±'));
        assert!(pointing_axis(3).contains("± std over seeds"));
        assert!(pointing_axis(1).contains("chance"));
    }
}
