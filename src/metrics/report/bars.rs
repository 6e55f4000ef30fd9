//! The level-keyed figures of a report (`eval --levels`): one row of bars per level, one bar per
//! series, and the legend in a strip under the plot. Inside the plot the legend covered a bar
//! (the longest one, at its lower right, in `levels_success.png` and `fig_exploration.png`):
//! bars run the whole width, so no corner of the plot is free.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{Cell, Report};
use crate::metrics::bands::{LEGEND_LINE, LEGEND_PAD, LEGEND_ROW, legend_layout};
use crate::metrics::error::MetricsError;
use crate::metrics::figures::{save_rgb, series_color};
use crate::metrics::sweep::MeanStd;

/// One bar of a level-keyed figure: its series, its value (mean ± std) and the reference it is
/// read against, where the figure marks one (a uniform map's value: chance).
pub(crate) type Bar = (String, MeanStd, Option<f64>);

/// The legend entry of the marks ([`Report::levels_bars_marked`]).
pub(crate) const MARK_LABEL: &str = "chance (a uniform map)";

/// The figure's width in pixels.
const WIDTH: u32 = 900;

/// The legend's entries: each series in its colour, then the marks (black) where some bar has
/// one.
fn legend_entries(names: &[String], marked: bool) -> Vec<(String, RGBColor, bool)> {
    let mut entries: Vec<(String, RGBColor, bool)> = names
        .iter()
        .enumerate()
        .map(|(j, n)| (n.clone(), series_color(j), false))
        .collect();
    if marked {
        entries.push((MARK_LABEL.to_owned(), BLACK, true));
    }
    entries
}

impl Report {
    /// A figure of one row of bars per level of the sweep, one bar per series `series` gives
    /// a cell (a value in [0, 1], mean ± std): the level-keyed form of the report's figures,
    /// whose paper form plots room size against object count.
    pub(crate) fn levels_bars(
        &self,
        path: &Path,
        title: &str,
        x_desc: &str,
        series: &dyn Fn(&Cell) -> Vec<(String, MeanStd)>,
    ) -> Result<(), MetricsError> {
        self.levels_bars_marked(path, title, x_desc, &|c: &Cell| -> Vec<Bar> {
            series(c)
                .into_iter()
                .map(|(name, m)| (name, m, None))
                .collect()
        })
    }

    /// The levels (as [`Cell::label`] names them) and the series of a level-keyed figure, each
    /// in order of first appearance.
    fn bar_rows(&self, series: &dyn Fn(&Cell) -> Vec<Bar>) -> (Vec<String>, Vec<String>) {
        let mut levels: Vec<String> = Vec::new();
        let mut names: Vec<String> = Vec::new();
        for c in self.level_cells() {
            if !levels.contains(&c.label()) {
                levels.push(c.label());
            }
            for (name, _, _) in series(c) {
                if !names.contains(&name) {
                    names.push(name);
                }
            }
        }
        (levels, names)
    }

    /// [`Report::levels_bars`] with a black tick across each bar at its mark (chance), the
    /// tick in the legend too; the legend in a strip under the plot.
    pub(crate) fn levels_bars_marked(
        &self,
        path: &Path,
        title: &str,
        x_desc: &str,
        series: &dyn Fn(&Cell) -> Vec<Bar>,
    ) -> Result<(), MetricsError> {
        crate::metrics::figures::register_font();
        let err = |e: &dyn std::fmt::Display| MetricsError::Io {
            path: path.to_path_buf(),
            reason: e.to_string(),
        };
        let (levels, names) = self.bar_rows(series);
        let marked = self
            .level_cells()
            .any(|c| series(c).iter().any(|b| b.2.is_some()));
        let entries = legend_entries(&names, marked);
        let font = ("sans-serif", 13).into_font();
        let widths = entries
            .iter()
            .map(|(label, _, _)| font.box_size(label).map(|(tw, _)| tw))
            .collect::<Result<Vec<u32>, _>>()
            .map_err(|e| err(&e))?;
        let places = legend_layout(&widths, WIDTH);
        let rows = places.iter().map(|p| p.1 + 1).max().unwrap_or(0);
        let row = 14 * names.len().max(1) as u32 + 10;
        let plot_h = 110 + row * levels.len().max(1) as u32;
        let h = plot_h + if rows == 0 { 0 } else { rows * LEGEND_ROW + 8 };
        let mut buf = vec![0u8; (WIDTH * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (WIDTH, h)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let (top, strip) = root.split_vertically(plot_h);
            self.draw_bars(
                &top,
                path,
                (title, x_desc),
                (levels.as_slice(), names.as_slice()),
                series,
            )?;
            for ((label, color, mark), (x, r)) in entries.iter().zip(places) {
                let (x, y) = (x as i32, (r * LEGEND_ROW + LEGEND_ROW / 2) as i32);
                if *mark {
                    strip
                        .draw(&PathElement::new(
                            vec![(x + 12, y - 7), (x + 12, y + 7)],
                            color.stroke_width(2),
                        ))
                        .map_err(|e| err(&e))?;
                } else {
                    strip
                        .draw(&Rectangle::new(
                            [(x + 6, y - 5), (x + 20, y + 5)],
                            color.filled(),
                        ))
                        .map_err(|e| err(&e))?;
                }
                let text = Text::new(
                    label.as_str(),
                    (x + (LEGEND_LINE + LEGEND_PAD) as i32, y),
                    font.color(&BLACK).pos(Pos::new(HPos::Left, VPos::Center)),
                );
                strip.draw(&text).map_err(|e| err(&e))?;
            }
            root.present().map_err(|e| err(&e))?;
        }
        save_rgb(&buf, WIDTH, h, path)
    }

    /// The plot of [`Report::levels_bars_marked`] on `area`: a row per level of `rows.0`, a bar
    /// per series of `rows.1` (± std where it is above 0), a black tick at each mark.
    fn draw_bars(
        &self,
        area: &DrawingArea<BitMapBackend<'_>, Shift>,
        path: &Path,
        (title, x_desc): (&str, &str),
        (levels, names): (&[String], &[String]),
        series: &dyn Fn(&Cell) -> Vec<Bar>,
    ) -> Result<(), MetricsError> {
        let err = |e: &dyn std::fmt::Display| MetricsError::Io {
            path: path.to_path_buf(),
            reason: e.to_string(),
        };
        let n = levels.len() as f64;
        let mut chart = ChartBuilder::on(area)
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
        let k = names.len().max(1) as f64;
        let h = 0.8 / k;
        for (j, name) in names.iter().enumerate() {
            let color = series_color(j);
            // (top of the bar, value, std, mark) of this series on each level.
            let bars: Vec<(f64, f64, f64, Option<f64>)> = self
                .level_cells()
                .flat_map(|c| series(c).into_iter().map(move |b| (c, b)))
                .filter(|(_, b)| b.0 == *name)
                .filter_map(|(c, (_, m, mark))| {
                    let i = levels.iter().position(|l| *l == c.label())? as f64;
                    let top = n - i - 0.1 - 0.8 * j as f64 / k;
                    Some((top, m.mean?.clamp(0.0, 1.0), m.std.unwrap_or(0.0), mark))
                })
                .collect();
            chart
                .draw_series(bars.iter().map(|&(top, m, _, _)| {
                    Rectangle::new([(0.0, top - h), (m, top)], color.filled())
                }))
                .map_err(|e| err(&e))?;
            chart
                .draw_series(bars.iter().filter(|b| b.2 > 0.0).map(|&(top, m, s, _)| {
                    PathElement::new(
                        vec![
                            ((m - s).max(0.0), top - h / 2.0),
                            ((m + s).min(1.0), top - h / 2.0),
                        ],
                        BLACK.stroke_width(1),
                    )
                }))
                .map_err(|e| err(&e))?;
            chart
                .draw_series(bars.iter().filter_map(|&(top, _, _, mark)| {
                    let x = mark?.clamp(0.0, 1.0);
                    Some(PathElement::new(
                        vec![(x, top), (x, top - h)],
                        BLACK.stroke_width(2),
                    ))
                }))
                .map_err(|e| err(&e))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::sweep::Performance;

    /// Bars at 1.000 run the plot's whole width, so no corner of the plot is free: the legend
    /// goes under it, and every bar keeps all its pixels (the legend inside, at the lower right,
    /// covered the end of the lowest bar).
    #[test]
    fn the_legend_sits_under_the_plot_and_hides_no_bar() {
        let m = |v: f64| MeanStd {
            mean: Some(v),
            std: Some(0.0),
        };
        let perf = Performance {
            reward: m(1.0),
            success: m(1.0),
            length: m(5.0),
            reward_given_success: m(1.0),
        };
        let cell = |id: &str| {
            Cell::new("ck", "baseline", 8, 0, 4, &perf, None).with_level(Some(id.to_owned()))
        };
        let report = Report::of_cells(
            vec![cell("BabyAI-GoToLocal-v0"), cell("BabyAI-PickupLoc-v0")],
            4,
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bars.png");
        report
            .levels_bars(&path, "Success rate per level", "success rate", &|c| {
                vec![(c.checkpoint.clone(), c.success)]
            })
            .unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        let color = series_color(0);
        let is_bar = |x: u32, y: u32| img.get_pixel(x, y).0 == [color.0, color.1, color.2];
        let span = |x: u32| (0..img.height()).filter(|&y| is_bar(x, y)).count();
        assert!(span(400) > 20, "{}", span(400));
        assert_eq!(span(880), span(400), "a bar's right end is hidden");
        // The legend's sample, in the series' colour, lies below the lowest bar.
        let lowest = (0..img.height()).filter(|&y| is_bar(400, y)).max().unwrap();
        assert!(
            (0..img.width()).any(|x| (lowest + 20..img.height()).any(|y| is_bar(x, y))),
            "no legend under the plot"
        );
    }

    #[test]
    fn the_legend_lists_every_series_then_the_marks() {
        let names = vec!["object".to_owned(), "color".to_owned()];
        let plain = legend_entries(&names, false);
        assert_eq!(
            plain.iter().map(|e| e.0.as_str()).collect::<Vec<_>>(),
            ["object", "color"]
        );
        assert_eq!(plain[1].1, series_color(1));
        let marked = legend_entries(&names, true);
        assert_eq!(marked.len(), 3);
        assert_eq!(marked[2].0, MARK_LABEL);
        assert!(marked[2].2 && !marked[0].2);
    }
}
