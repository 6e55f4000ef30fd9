//! The report's figures: one panel per room size, a line with ±std error bars per series.

use std::path::Path;

use plotters::prelude::*;

use super::{Cell, FIG7_OBJECT, FIG8_COLOR, Point, Report};
use crate::metrics::error::MetricsError;
use crate::metrics::figures::{save_rgb, series_color};
use crate::metrics::grounding::WordKind;
use crate::metrics::sweep::MeanStd;

impl Report {
    /// One PNG: a panel per room size, x = object count, a line (with ±std error bars) per
    /// series that `series` returns for each cell.
    pub(in crate::metrics) fn figure(
        &self,
        path: &Path,
        title: &str,
        series: &dyn Fn(&Cell) -> Vec<(String, MeanStd)>,
    ) -> Result<(), MetricsError> {
        self.figure_of(path, title, &|_| true, series)
    }

    /// [`Report::figure`] of the cells `keep` accepts (the paper's figures: the paper's
    /// level's cells).
    pub(in crate::metrics) fn figure_of(
        &self,
        path: &Path,
        title: &str,
        keep: &dyn Fn(&Cell) -> bool,
        series: &dyn Fn(&Cell) -> Vec<(String, MeanStd)>,
    ) -> Result<(), MetricsError> {
        let cells = || self.cells.iter().filter(|c| keep(c));
        crate::metrics::figures::register_font();
        let err = |e: &dyn std::fmt::Display| MetricsError::Io {
            path: path.to_path_buf(),
            reason: e.to_string(),
        };
        let mut sizes: Vec<usize> = cells().map(|c| c.size).collect();
        sizes.sort_unstable();
        sizes.dedup();
        let mut objects: Vec<usize> = cells().map(|c| c.objects).collect();
        objects.sort_unstable();
        objects.dedup();
        let (x_lo, x_hi) = (
            objects.first().copied().unwrap_or(0) as f64 - 0.5,
            objects.last().copied().unwrap_or(1) as f64 + 0.5,
        );
        let panel_w = 340u32;
        // One panel alone would cut the figure's title: the figure is at least 680 wide.
        let (w, h) = ((panel_w * sizes.len().max(1) as u32).max(680), 420u32);
        let mut buf = vec![0u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let root = root
                .titled(title, ("sans-serif", 22))
                .map_err(|e| err(&e))?;
            let panels = root.split_evenly((1, sizes.len().max(1)));
            for (panel, &size) in panels.iter().zip(&sizes) {
                let mut chart = ChartBuilder::on(panel)
                    .caption(format!("{size}×{size} room"), ("sans-serif", 16))
                    .margin(8)
                    .x_label_area_size(36)
                    .y_label_area_size(44)
                    .build_cartesian_2d(x_lo..x_hi, 0.0..1.05f64)
                    .map_err(|e| err(&e))?;
                chart
                    .configure_mesh()
                    .x_desc("objects")
                    .x_labels(objects.len().max(2))
                    .x_label_formatter(&|x| format!("{x:.0}"))
                    .label_style(("sans-serif", 12))
                    .draw()
                    .map_err(|e| err(&e))?;
                // (label, [(objects, mean, std)]) per line of the panel.
                let mut lines: Vec<(String, Vec<Point>)> = Vec::new();
                for c in cells().filter(|c| c.size == size) {
                    for (label, m) in series(c) {
                        let (Some(mean), Some(std)) = (m.mean, m.std) else {
                            continue;
                        };
                        match lines.iter_mut().find(|(l, _)| *l == label) {
                            Some((_, pts)) => pts.push((c.objects as f64, mean, std)),
                            None => lines.push((label, vec![(c.objects as f64, mean, std)])),
                        }
                    }
                }
                for (i, (label, pts)) in lines.iter().enumerate() {
                    let color = series_color(i);
                    // Series side by side at each x, so that equal values do not hide one
                    // another; a marker on every point, so that a one-point series shows.
                    let dx = (i as f64 - (lines.len() - 1) as f64 / 2.0) * 0.1;
                    chart
                        .draw_series(LineSeries::new(
                            pts.iter().map(|p| (p.0 + dx, p.1)),
                            color.stroke_width(2),
                        ))
                        .map_err(|e| err(&e))?
                        .label(label.clone())
                        .legend(move |(x, y)| {
                            EmptyElement::at((x, y))
                                + PathElement::new(vec![(0, 0), (20, 0)], color.stroke_width(2))
                                + Circle::new((10, 0), 4, color.filled())
                        });
                    chart
                        .draw_series(
                            pts.iter()
                                .map(|p| Circle::new((p.0 + dx, p.1), 4, color.filled())),
                        )
                        .map_err(|e| err(&e))?;
                    chart
                        .draw_series(pts.iter().map(|&(x, m, s)| {
                            ErrorBar::new_vertical(
                                x + dx,
                                (m - s).max(0.0),
                                m,
                                (m + s).min(1.05),
                                color.filled(),
                                8,
                            )
                        }))
                        .map_err(|e| err(&e))?;
                }
                chart
                    .configure_series_labels()
                    .position(SeriesLabelPosition::LowerLeft)
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 12))
                    .draw()
                    .map_err(|e| err(&e))?;
            }
            root.present().map_err(|e| err(&e))?;
        }
        save_rgb(&buf, w, h, path)
    }
}

impl Report {
    /// The paper's Figs. 7 and 8 (the object and colour words' four accuracies) of the cells
    /// `paper` accepts, into `staged`.
    pub(super) fn accuracy_figures(
        &self,
        staged: &crate::files::StagedDir,
        paper: &dyn Fn(&Cell) -> bool,
    ) -> Result<(), MetricsError> {
        for (name, kind, title) in [
            (
                FIG7_OBJECT,
                WordKind::Object,
                "Object-word map accuracy (Fig. 7)",
            ),
            (
                FIG8_COLOR,
                WordKind::Color,
                "Colour-word map accuracy (Fig. 8)",
            ),
        ] {
            self.figure_of(&staged.path(name), title, paper, &|c| {
                let Some(a) = &c.accuracy else {
                    return Vec::new();
                };
                let g = if kind == WordKind::Object {
                    &a.object
                } else {
                    &a.color
                };
                let prefix = if self
                    .checkpoints
                    .iter()
                    .filter(|k| k.variant == "attention")
                    .count()
                    > 1
                {
                    format!("{} ", c.checkpoint)
                } else {
                    String::new()
                };
                vec![
                    (format!("{prefix}acc"), g.acc),
                    (format!("{prefix}acc_ng"), g.acc_ng),
                    (format!("{prefix}acc_bs"), g.acc_bs),
                    (format!("{prefix}acc_cmb"), g.acc_cmb),
                ]
            })?;
        }
        Ok(())
    }
}
