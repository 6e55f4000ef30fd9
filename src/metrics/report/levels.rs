//! What a sweep over BabyAI levels (`eval --levels`) adds to a report: the per-level table of
//! `report.md` and the per-level figure (its `episodes.csv` is [`super::episodes`]'s).

use std::fmt::Write as _;
use std::path::Path;

use super::{Cell, Report};
use crate::metrics::error::MetricsError;
use crate::metrics::grounding::WordKind;
use crate::metrics::words::steps_label;

/// The per-level success figure (`eval --levels`).
pub const LEVELS_SUCCESS: &str = "levels_success.png";

impl Report {
    /// The cells on registered BabyAI levels.
    pub fn level_cells(&self) -> impl Iterator<Item = &Cell> {
        self.cells.iter().filter(|c| c.level.is_some())
    }

    /// `report.md`'s per-level table: success, reward, length and each word kind's `acc_ng`
    /// per checkpoint and level (empty when the sweep has no BabyAI level).
    pub(super) fn levels_markdown(&self) -> String {
        let mut s = String::new();
        if !self.has_levels() {
            return s;
        }
        let kinds = WordKind::ALL;
        let _ = writeln!(s, "\n## Per level\n");
        let _ = writeln!(
            s,
            "`acc_ng` per word kind, with the evaluated steps behind it; – where the level's missions hold no such word or the model has no maps. \
             Beside minigrid's bot (docs/bot.md): *agree*, the share of steps at which the agent took the bot's \
             action; *diverge*, the step at which a failed episode first left the bot's plan at a cost (a tie such as left or right at the start is passed over); *efficiency*, the \
             bot's steps alone / the agent's on successful episodes; *bot*, the bot's own success from the same starts.\n"
        );
        let names: Vec<String> = kinds
            .iter()
            .map(|k| format!("{} acc_ng", k.name()))
            .collect();
        let _ = writeln!(
            s,
            "| checkpoint | level | episodes | success | reward | length | {} | agree | diverge | efficiency | bot |",
            names.join(" | ")
        );
        let _ = writeln!(
            s,
            "|---|---|---|---|---|---|{}---|---|---|---|",
            "---|".repeat(kinds.len())
        );
        for c in self.level_cells() {
            let accs: Vec<String> = kinds
                .iter()
                .map(|&k| {
                    c.accuracy
                        .as_ref()
                        .and_then(|a| a.of(k))
                        .and_then(|g| {
                            g.acc_ng.mean.map(|_| {
                                format!(
                                    "{} ({})",
                                    self.over_seeds(&g.acc_ng),
                                    steps_label(g.evaluated_steps)
                                )
                            })
                        })
                        .unwrap_or_else(|| "–".into())
                })
                .collect();
            // MiniGrid's own environments have no BabyAI instruction for the bot to plan, but
            // those rewarded for one pickup (`crate::bot::plans`).
            let no_expert = c.level.as_deref().is_some_and(|id| {
                crate::env::LevelId::parse(id)
                    .is_ok_and(|l| l.minigrid().is_some_and(|m| !m.rewards_one_pickup()))
            });
            let expert: Vec<String> = c.expert.as_ref().filter(|_| !no_expert).map_or_else(
                || vec![if no_expert { "none" } else { "–" }.to_string(); 4],
                |x| {
                    [
                        &x.agreement,
                        &x.first_divergence,
                        &x.path_efficiency,
                        &x.bot_success,
                    ]
                    .into_iter()
                    .map(|m| m.mean.map_or_else(|| "–".into(), |_| self.over_seeds(m)))
                    .collect()
                },
            );
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} |",
                c.checkpoint,
                c.label(),
                c.episodes,
                self.over_seeds(&c.success),
                self.over_seeds(&c.reward),
                self.over_seeds(&c.length),
                accs.join(" | "),
                expert.join(" | ")
            );
        }
        let _ = writeln!(s, "\n![Success rate per level]({LEVELS_SUCCESS})");
        s
    }

    /// `levels_success.png`: the success rate of every checkpoint on every level of the
    /// sweep, one row of bars per level (± std over seeds where there are several seeds).
    pub(super) fn levels_figure(&self, path: &Path) -> Result<(), MetricsError> {
        self.levels_bars(
            path,
            "Success rate per level",
            success_axis(self.seeds),
            &|c| vec![(c.checkpoint.clone(), c.success)],
        )
    }
}

/// The value axis of `levels_success.png`: a spread over seeds is named only where there are
/// seeds to spread over (one seed's std is 0 by definition, and no line is drawn).
pub(crate) fn success_axis(seeds: u64) -> &'static str {
    if seeds >= 2 {
        "success rate (mean over seeds; line: ± std over seeds)"
    } else {
        "success rate (one seed: its mean)"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_success_axis_names_a_spread_only_over_several_seeds() {
        assert!(!success_axis(1).contains('±'), "{}", success_axis(1));
        assert!(success_axis(2).contains("± std over seeds"));
        assert!(success_axis(5).contains("± std over seeds"));
    }
}
