//! What a sweep over BabyAI levels (`eval --levels`) adds to a report: `episodes.csv`, every
//! episode on one line so that it can be lined up with another evaluation of the same levels
//! and seeds (`export/eval_in_python.py`); the per-level table of `report.md`; and the
//! per-level figure.

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;

use super::{Cell, Report};
use crate::env::level::LevelConfig;
use crate::metrics::error::MetricsError;
use crate::metrics::failure::FailureClass;
use crate::metrics::figures::{save_rgb, series_color};
use crate::metrics::grounding::WordKind;
use crate::metrics::sweep::{EpisodeSummary, MeanStd};
use crate::table::{Record, Table};

/// `episodes.csv`'s header.
pub const EPISODES_CSV_HEADER: &str = "checkpoint,level,eval_seed,episode,level_seed,mission,success,steps,return,failure_class,actions,expert_agreement,first_divergence,bot_steps,path_efficiency,behaviour,done_required,decisive_step";

/// `episodes.csv`: one line per episode of every cell, in sweep order (cells as evaluated,
/// then evaluation seed, then episode): the level, its seed, the mission, the outcome, the
/// failure class, the actions taken (indices, space-separated), the episode beside the bot,
/// the done mode it ran in (`done_required`: 1 where 'done' had to end it) and, for a failure,
/// the step it opens at ([`crate::metrics::failure::decisive_step`]).
pub fn episodes_csv(cells: &[(String, LevelConfig, Vec<EpisodeSummary>)]) -> String {
    let mut t = Table::new(EPISODES_CSV_HEADER);
    for (checkpoint, level, eps) in cells {
        let name = level.id();
        let mut index = 0u64;
        let mut seed = None;
        for e in eps {
            if seed != Some(e.eval_seed) {
                (seed, index) = (Some(e.eval_seed), 0);
            }
            let actions: Vec<String> = e.actions.iter().map(u8::to_string).collect();
            let x = &e.expert;
            let number = |v: f64| {
                if v.is_finite() {
                    format!("{v:.6}")
                } else {
                    String::new()
                }
            };
            t.push(
                &Record::new()
                    .field(checkpoint)
                    .field(&name)
                    .field(e.eval_seed)
                    .field(index)
                    .field(e.level_seed)
                    .field(&e.mission)
                    .field(u8::from(e.success))
                    .field(e.length)
                    .field(format!("{:.6}", e.reward))
                    .field(e.failure.map_or("", |d| d.class.name()))
                    .field(actions.join(" "))
                    .field(number(x.agreement()))
                    .field(x.first_divergence.map_or(String::new(), |t| t.to_string()))
                    .field(x.bot_length.map_or(String::new(), |n| n.to_string()))
                    .field(number(x.path_efficiency(e.success, e.length)))
                    .field(
                        e.failure
                            .and_then(|d| d.behaviour)
                            .map_or("", FailureClass::name),
                    )
                    .field(u8::from(level.done_required))
                    .field(e.failure.map_or(String::new(), |d| {
                        crate::metrics::failure::decisive_step(
                            d.lost_at,
                            x.first_divergence,
                            e.length,
                        )
                        .to_string()
                    })),
            );
            index += 1;
        }
    }
    t.finish()
}

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
            "`acc_ng` per word kind; – where the level's missions hold no such word or the model has no maps. \
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
                        .and_then(|g| g.acc_ng.mean.map(|_| self.over_seeds(&g.acc_ng)))
                        .unwrap_or_else(|| "–".into())
                })
                .collect();
            // MiniGrid's own environments have no BabyAI instruction for the bot to plan.
            let minigrid = c.level.as_deref().is_some_and(|id| {
                crate::env::LevelId::parse(id).is_ok_and(|l| l.minigrid().is_some())
            });
            let expert: Vec<String> = c.expert.as_ref().filter(|_| !minigrid).map_or_else(
                || vec![if minigrid { "none" } else { "–" }.to_string(); 4],
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
        s
    }

    /// `levels_success.png`: the success rate (± std over seeds) of every checkpoint on every
    /// level of the sweep, one row of bars per level.
    pub(super) fn levels_figure(&self, path: &Path) -> Result<(), MetricsError> {
        self.levels_bars(
            path,
            "Success rate per level",
            "success rate (mean over seeds; line: ± std)",
            &|c| vec![(c.checkpoint.clone(), c.success)],
        )
    }

    /// A figure of one row of bars per level of the sweep, one bar per series `series` gives
    /// a cell (a value in [0, 1], mean ± std over seeds): the level-keyed form of the
    /// report's figures, whose paper form plots room size against object count.
    pub(crate) fn levels_bars(
        &self,
        path: &Path,
        title: &str,
        x_desc: &str,
        series: &dyn Fn(&Cell) -> Vec<(String, MeanStd)>,
    ) -> Result<(), MetricsError> {
        crate::metrics::figures::register_font();
        let err = |e: &dyn std::fmt::Display| MetricsError::Io {
            path: path.to_path_buf(),
            reason: e.to_string(),
        };
        let mut levels: Vec<String> = Vec::new();
        let mut ckpts: Vec<String> = Vec::new();
        for c in self.level_cells() {
            if !levels.contains(&c.label()) {
                levels.push(c.label());
            }
            for (name, _) in series(c) {
                if !ckpts.contains(&name) {
                    ckpts.push(name);
                }
            }
        }
        let row = 14 * ckpts.len().max(1) as u32 + 10;
        let (w, h) = (900u32, 110 + row * levels.len().max(1) as u32);
        let mut buf = vec![0u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let n = levels.len() as f64;
            let mut chart = ChartBuilder::on(&root)
                .caption(title, ("sans-serif", 22))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(300)
                .build_cartesian_2d(0.0..1.0f64, 0.0..n)
                .map_err(|e| err(&e))?;
            let label_of = |y: &f64| {
                let i = (n - y - 0.5).round();
                if (n - y - 0.5 - i).abs() < 1e-6 && i >= 0.0 {
                    levels.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            };
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .y_labels(levels.len() * 2 + 1)
                .y_label_formatter(&label_of)
                .label_style(("sans-serif", 13))
                .disable_y_mesh()
                .draw()
                .map_err(|e| err(&e))?;
            let k = ckpts.len().max(1) as f64;
            for (j, ckpt) in ckpts.iter().enumerate() {
                let color = series_color(j);
                let bars: Vec<(f64, f64, f64)> = self
                    .level_cells()
                    .flat_map(|c| series(c).into_iter().map(move |(name, m)| (c, name, m)))
                    .filter(|(_, name, _)| name == ckpt)
                    .filter_map(|(c, _, m)| {
                        let i = levels.iter().position(|l| *l == c.label())? as f64;
                        let top = n - i - 0.1 - 0.8 * j as f64 / k;
                        Some((top, m.mean?.clamp(0.0, 1.0), m.std.unwrap_or(0.0)))
                    })
                    .collect();
                let h = 0.8 / k;
                chart
                    .draw_series(bars.iter().map(|&(top, m, _)| {
                        Rectangle::new([(0.0, top - h), (m, top)], color.filled())
                    }))
                    .map_err(|e| err(&e))?
                    .label(ckpt.clone())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 14, y + 5)], color.filled())
                    });
                chart
                    .draw_series(bars.iter().filter(|b| b.2 > 0.0).map(|&(top, m, s)| {
                        PathElement::new(
                            vec![
                                ((m - s).max(0.0), top - h / 2.0),
                                ((m + s).min(1.0), top - h / 2.0),
                            ],
                            BLACK.stroke_width(1),
                        )
                    }))
                    .map_err(|e| err(&e))?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.9))
                .border_style(BLACK)
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))?;
        }
        save_rgb(&buf, w, h, path)
    }
}
