//! The exploration outputs of an evaluation report: `exploration.csv`, the `report.md`
//! tables and the figures. Everything reads the cells' [`CellExploration`], so the files agree
//! with `report.json`.

use std::fmt::Write as _;
use std::path::Path;

use super::{CellExploration, CellMapStats, ExplorationStats};
use crate::metrics::error::MetricsError;
use crate::metrics::report::{Cell, Report};
use crate::metrics::sweep::MeanStd;
use crate::table::{Record, Table};

/// The `exploration.csv` header (documented in `docs/exploration.md`).
pub const EXPLORATION_CSV_HEADER: &str = "checkpoint,variant,size,objects,outcome,episodes,\
steps_mean,steps_std,visited_mean,visited_std,visited_frac_mean,visited_frac_std,\
seen_frac_mean,seen_frac_std,turn_frac_mean,turn_frac_std,\
longest_turn_run_mean,longest_turn_run_std,revisit_frac_mean,revisit_frac_std,\
never_visible,truncated,first_visible_step_mean,first_visible_step_std,\
hidden_steps,visible_steps,\
m_entropy_hidden_mean,m_entropy_hidden_std,m_entropy_visible_mean,m_entropy_visible_std,\
m_max_hidden_mean,m_max_hidden_std,m_max_visible_mean,m_max_visible_std,\
w_entropy_hidden_mean,w_entropy_hidden_std,w_entropy_visible_mean,w_entropy_visible_std,\
word_entropy_hidden_mean,word_entropy_hidden_std,word_entropy_visible_mean,word_entropy_visible_std";

/// The figure with the failures' coverage (every report).
pub const FIG_EXPLORATION: &str = "fig_exploration.png";
/// The figure with `M`'s entropy while a target is hidden / visible (attention reports only).
pub const FIG_EXPLORATION_MAPS: &str = "fig_exploration_maps.png";

/// The value axis of an exploration figure drawn as a row of bars per level: what its bars
/// measure, and that their spread is over episodes. [`FIG_EXPLORATION_MAPS`] plots a
/// normalised entropy, not a share.
pub(crate) fn value_axis(figure: &str) -> &'static str {
    if figure == FIG_EXPLORATION_MAPS {
        "H(M) / ln 49 (normalised entropy; mean over episodes; line: ± std over episodes)"
    } else {
        "share of the floor ever seen (mean over failed episodes; line: ± std over them)"
    }
}

/// The map columns of one CSV row: the steps, then each measure hidden and visible. A set
/// without maps (a baseline's, or no episode) leaves all 18 fields empty: its steps were not
/// split, which is not zero.
fn map_fields(s: &ExplorationStats) -> Record {
    let Some(m) = &s.maps else {
        return (0..18).fold(Record::new(), |r, _| r.field(""));
    };
    let stats: [fn(&CellMapStats) -> &MeanStd; 4] = [
        |x| &x.m_entropy,
        |x| &x.m_max,
        |x| &x.w_entropy,
        |x| &x.word_entropy,
    ];
    stats.iter().fold(
        Record::new().field(m.hidden.steps).field(m.visible.steps),
        |r, f| r.mean_std(f(&m.hidden)).mean_std(f(&m.visible)),
    )
}

/// A mean with three decimals, `–` when nothing was measured.
fn mean3(m: &MeanStd) -> String {
    m.mean.map_or("–".into(), |v| format!("{v:.3}"))
}

/// Legend labels for the checkpoints: their file names when those are unique (the full
/// names of run directories make legends wider than a panel), else the names as given.
fn labels(report: &Report) -> Vec<(String, String)> {
    let short: Vec<String> = report
        .checkpoints
        .iter()
        .map(|c| {
            Path::new(&c.name)
                .file_name()
                .map_or(c.name.clone(), |f| f.to_string_lossy().into_owned())
        })
        .collect();
    let mut sorted = short.clone();
    sorted.sort();
    sorted.dedup();
    let unique = sorted.len() == short.len();
    report
        .checkpoints
        .iter()
        .zip(short)
        .map(|(c, s)| (c.name.clone(), if unique { s } else { c.name.clone() }))
        .collect()
}

/// The attention checkpoints' maps while a target is hidden / visible, all episodes.
fn maps_table(report: &Report, with: &[&Cell], s: &mut String) {
    let rows: Vec<(&Cell, &super::CellMapSplit)> = with
        .iter()
        .filter_map(|c| Some((*c, c.exploration.as_ref()?.all.maps.as_ref()?)))
        .collect();
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\n## The maps while no target is in view (not in the paper)\n"
    );
    let _ = writeln!(
        s,
        "Normalised entropy of `M` (`H(M) / ln 49`: 1 = uniform), its largest value and the \
         normalised entropy of the word weights (`H(w) / ln m`), each averaged over the steps \
         of an episode with no target visible (hidden) and with one (visible), then over \
         the episodes (all outcomes).\n"
    );
    let _ = writeln!(
        s,
        "{} hidden steps | H(M) hidden | H(M) visible | max M hidden | max M visible | H(w) hidden | H(w) visible |",
        report.key_header()
    );
    let _ = writeln!(s, "{}---|---|---|---|---|---|---|", report.key_rule());
    for (c, m) in rows {
        let _ = writeln!(
            s,
            "{} {} | {} | {} | {} | {} | {} | {} |",
            report.cell_key(c),
            m.hidden.steps,
            mean3(&m.hidden.m_entropy),
            mean3(&m.visible.m_entropy),
            mean3(&m.hidden.m_max),
            mean3(&m.visible.m_max),
            mean3(&m.hidden.w_entropy),
            mean3(&m.visible.w_entropy)
        );
    }
    let _ = writeln!(
        s,
        "\n![H(M) / ln 49 while no target is visible (hidden) and while one is]({FIG_EXPLORATION_MAPS})"
    );
}

impl Report {
    /// `exploration.csv`: one line per cell and outcome (`all`, `success`, `failure`).
    pub fn exploration_csv(&self) -> String {
        let mut t = Table::new(&self.csv_header(EXPLORATION_CSV_HEADER));
        for c in &self.cells {
            let Some(x) = &c.exploration else { continue };
            for (outcome, e) in x.outcomes() {
                t.push(
                    &self.csv_level(
                        Record::new()
                            .field(&c.checkpoint)
                            .field(&c.variant)
                            .field(c.size)
                            .field(c.objects)
                            .field(outcome)
                            .field(e.episodes)
                            .mean_std(&e.steps)
                            .mean_std(&e.visited)
                            .mean_std(&e.visited_frac)
                            .mean_std(&e.seen_frac)
                            .mean_std(&e.turn_frac)
                            .mean_std(&e.longest_turn_run)
                            .mean_std(&e.revisit_frac)
                            .field(e.never_visible)
                            .field(e.truncated)
                            .mean_std(&e.first_visible_step)
                            .extend(map_fields(e)),
                        c,
                    ),
                );
            }
        }
        t.finish()
    }

    /// The `report.md` sections: the failures' coverage per cell, one column per checkpoint;
    /// then, for attention checkpoints, the maps while a target is hidden and visible.
    pub(crate) fn exploration_tables(&self, s: &mut String) {
        let with: Vec<&Cell> = self
            .cells
            .iter()
            .filter(|c| c.exploration.is_some())
            .collect();
        if with.is_empty() {
            return;
        }
        let _ = writeln!(
            s,
            "\n## Exploration of the failed episodes (not in the paper)\n"
        );
        let _ = writeln!(
            s,
            "Per checkpoint: failed episodes, then their mean share of the room's floor ever \
             seen / stood on / steps spent turning (mean over the failed episodes; \
             `exploration.csv` has the std, the successes and more; see docs/exploration.md).\n"
        );
        let names: Vec<&str> = self.checkpoints.iter().map(|c| c.name.as_str()).collect();
        let key = if self.has_levels() {
            "| level | grid | rooms |"
        } else {
            "| size | objects |"
        };
        let rule = if self.has_levels() {
            "|---|---|---|"
        } else {
            "|---|---|"
        };
        let _ = writeln!(s, "{key} {} |", names.join(" | "));
        let _ = writeln!(s, "{rule}{}", "---|".repeat(names.len()));
        // A BabyAI level is its own row: two levels of one room size must not share one.
        let mut keys: Vec<(usize, usize, Option<&str>)> = Vec::new();
        for c in &with {
            let key = (c.size, c.objects, c.level.as_deref());
            if !keys.contains(&key) {
                keys.push(key);
            }
        }
        for (size, objects, level) in keys {
            let cols: Vec<String> = names
                .iter()
                .map(|n| {
                    let x = with
                        .iter()
                        .find(|c| {
                            c.checkpoint == *n
                                && (c.size, c.objects, c.level.as_deref()) == (size, objects, level)
                        })
                        .and_then(|c| c.exploration.as_ref());
                    match x {
                        Some(CellExploration { failure: f, .. }) if f.episodes > 0 => format!(
                            "{}: {} / {} / {}",
                            f.episodes,
                            mean3(&f.seen_frac),
                            mean3(&f.visited_frac),
                            mean3(&f.turn_frac)
                        ),
                        Some(_) => "0".into(),
                        None => "–".into(),
                    }
                })
                .collect();
            if self.has_levels() {
                let key = crate::metrics::report::markdown::level_key(level, size, objects);
                let _ = writeln!(s, "| {key} | {} |", cols.join(" | "));
            } else {
                let _ = writeln!(s, "| {size} | {objects} | {} |", cols.join(" | "));
            }
        }
        let _ = writeln!(
            s,
            "\n![Failed episodes: share of the floor ever seen]({FIG_EXPLORATION})"
        );
        maps_table(self, &with, s);
    }

    /// Draws the exploration figures into `dir`; returns the names of those written
    /// ([`FIG_EXPLORATION`] always when any cell has exploration numbers,
    /// [`FIG_EXPLORATION_MAPS`] when an attention cell has).
    pub(crate) fn exploration_figures(
        &self,
        dir: &Path,
    ) -> Result<Vec<&'static str>, MetricsError> {
        let mut written = Vec::new();
        if !self.cells.iter().any(|c| c.exploration.is_some()) {
            return Ok(written);
        }
        let labels = labels(self);
        let label = |c: &Cell| {
            labels
                .iter()
                .find(|(n, _)| *n == c.checkpoint)
                .map_or(c.checkpoint.clone(), |(_, l)| l.clone())
        };
        // A sweep over BabyAI levels plots a row per level; the paper's, size × objects.
        let figure = |name: &str,
                      title: &str,
                      series: &dyn Fn(&Cell) -> Vec<(String, MeanStd)>|
         -> Result<(), MetricsError> {
            let path = dir.join(name);
            if self.has_levels() {
                self.levels_bars(&path, title, value_axis(name), series)
            } else {
                self.figure(&path, title, series)
            }
        };
        figure(
            FIG_EXPLORATION,
            "Failed episodes: share of the floor ever seen",
            &|c| {
                c.exploration
                    .as_ref()
                    .map(|x| vec![(label(c), x.failure.seen_frac)])
                    .unwrap_or_default()
            },
        )?;
        written.push(FIG_EXPLORATION);
        let any_maps = self
            .cells
            .iter()
            .any(|c| c.exploration.as_ref().is_some_and(|x| x.all.maps.is_some()));
        if any_maps {
            figure(
                FIG_EXPLORATION_MAPS,
                "H(M) / ln 49 while no target is visible (hidden) and while one is",
                &|c| {
                    let Some(m) = c.exploration.as_ref().and_then(|x| x.all.maps.as_ref()) else {
                        return Vec::new();
                    };
                    let l = label(c);
                    vec![
                        (format!("{l} hidden"), m.hidden.m_entropy),
                        (format!("{l} visible"), m.visible.m_entropy),
                    ]
                },
            )?;
            written.push(FIG_EXPLORATION_MAPS);
        }
        Ok(written)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The maps figure plots `H(M) / ln 49`, and its axis says so: not a "share".
    #[test]
    fn each_exploration_figure_names_what_it_plots() {
        let maps = value_axis(FIG_EXPLORATION_MAPS);
        assert!(
            maps.starts_with("H(M) / ln 49 (normalised entropy"),
            "{maps}"
        );
        assert!(!maps.contains("share"), "{maps}");
        let seen = value_axis(FIG_EXPLORATION);
        assert!(seen.starts_with("share of the floor ever seen"), "{seen}");
        assert!(seen.contains("± std over"), "{seen}");
    }
}
