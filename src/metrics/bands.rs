//! Several training runs of one recipe drawn as a mean ± std band, and the grounding-emergence
//! figure (accuracies of the tracked held-out evaluation against frames, `eval_log.csv`).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::error::MetricsError;
use super::figures::{register_font, save_rgb, series_color};

/// A recipe's runs reduced to one line: `(frames, mean, std over runs, runs)` per bin.
#[derive(Clone, Debug)]
pub struct Band {
    /// Legend label (the recipe: run names less their seed suffix).
    pub label: String,
    /// Points in frame order.
    pub points: Vec<(f64, f64, f64, usize)>,
}

/// The recipe a run directory belongs to: its name without a trailing seed suffix
/// (`babyai-s2`, `att_seed3`, `x-seed1` → `babyai`, `att`, `x`).
pub fn recipe_of(run: &str) -> String {
    for sep in ["-seed", "_seed", "-s", "_s"] {
        if let Some(i) = run.rfind(sep) {
            let tail = &run[i + sep.len()..];
            if !tail.is_empty() && tail.bytes().all(|b| b.is_ascii_digit()) {
                return run[..i].to_owned();
            }
        }
    }
    run.to_owned()
}

/// A training log's run name and the tracked evaluation that goes with it: a run directory's
/// `RUN/log.csv` → (`RUN`, `RUN/eval_log.csv`), and a bundled flat file `DIR/NAME_log.csv`
/// (`experiments/runs/attention_seed1_log.csv`) → (`NAME`, `DIR/NAME_eval_log.csv`).
pub fn run_files(log: &std::path::Path) -> (String, std::path::PathBuf) {
    let file = log
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    match file.strip_suffix("_log.csv").filter(|n| !n.is_empty()) {
        Some(name) => (
            name.to_owned(),
            log.with_file_name(format!("{name}_eval_log.csv")),
        ),
        None => (
            log.parent().and_then(|p| p.file_name()).map_or_else(
                || log.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            ),
            log.with_file_name("eval_log.csv"),
        ),
    }
}

/// Reduces runs (each a list of `(frames, y)`) to a band: each run is averaged within `bins`
/// equal frame intervals up to the longest run, then mean and population std are taken over
/// the runs that reached that interval.
pub fn band(label: &str, runs: &[Vec<(f64, f64)>], bins: usize) -> Band {
    let x_max = runs
        .iter()
        .flat_map(|r| r.iter().map(|p| p.0))
        .fold(0.0f64, f64::max);
    let bins = bins.max(1);
    let width = (x_max / bins as f64).max(1.0);
    let mut points = Vec::new();
    for b in 0..bins {
        let (lo, hi) = (b as f64 * width, (b + 1) as f64 * width);
        let per_run: Vec<f64> = runs
            .iter()
            .filter_map(|r| {
                let ys: Vec<f64> = r
                    .iter()
                    .filter(|p| p.0 > lo && p.0 <= hi && p.1.is_finite())
                    .map(|p| p.1)
                    .collect();
                (!ys.is_empty()).then(|| ys.iter().sum::<f64>() / ys.len() as f64)
            })
            .collect();
        if per_run.is_empty() {
            continue;
        }
        let n = per_run.len() as f64;
        let mean = per_run.iter().sum::<f64>() / n;
        let std = (per_run.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / n).sqrt();
        points.push((f64::midpoint(lo, hi), mean, std, per_run.len()));
    }
    Band {
        label: label.to_owned(),
        points,
    }
}

/// Reads columns of a CSV log as numbers, one row per line. The first column named is the x
/// axis (frames): a finite number on every line. In the others an empty field or `NaN` is NaN,
/// a metric that was not measured (an update that ended no episode logs `NaN`), drawn as a
/// gap; an infinity is refused (no axis reaches it). Names the file, line and column of
/// anything else.
pub fn read_columns(path: &Path, names: &[&str]) -> Result<Vec<Vec<f64>>, MetricsError> {
    let io = |e: std::io::Error| MetricsError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let text = crate::files::read_regular_to_string(path).map_err(io)?;
    // The one CSV reader (quoted fields, ragged lines named by their number).
    let (header, records) = crate::table::read(&text).map_err(|reason| MetricsError::Format {
        path: path.to_path_buf(),
        field: "CSV".into(),
        reason,
    })?;
    let cols = names
        .iter()
        .map(|name| {
            header
                .iter()
                .position(|h| h == name)
                .ok_or_else(|| MetricsError::Format {
                    path: path.to_path_buf(),
                    field: (*name).to_owned(),
                    reason: "column missing from the header".into(),
                })
        })
        .collect::<Result<Vec<usize>, _>>()?;
    let mut rows = Vec::new();
    for (i, cells) in records.iter().enumerate() {
        let mut row = Vec::with_capacity(cols.len());
        for (k, (&c, name)) in cols.iter().zip(names).enumerate() {
            let value = match cells.get(c).map(String::as_str) {
                Some(v) if k == 0 => v.parse::<f64>().ok().filter(|x| x.is_finite()),
                Some("") => Some(f64::NAN),
                Some(v) => v.parse::<f64>().ok().filter(|x| !x.is_infinite()),
                None => None,
            };
            let Some(value) = value else {
                return Err(MetricsError::Format {
                    path: path.to_path_buf(),
                    field: format!("line {} column {name}", i + 2),
                    reason: if k == 0 {
                        "the x axis needs a finite number here".into()
                    } else {
                        "a value is missing, not a number or infinite".into()
                    },
                });
            };
            row.push(value);
        }
        rows.push(row);
    }
    Ok(rows)
}

/// Draws one panel per `(title, y label, bands)` side by side: each band a mean line with a
/// shaded ±std region (no region where a recipe has one run), and one legend for all panels in
/// a strip below them — with several runs every corner of a panel holds a curve, and a legend
/// inside hid some (the grounding study's five runs).
pub fn band_panels(
    panels: &[(String, Vec<Band>)],
    title: &str,
    path: &Path,
) -> Result<(), MetricsError> {
    register_font();
    let err = |e: &dyn std::fmt::Display| MetricsError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let panel_w = 460u32;
    // At least wide enough for the title over a single panel.
    let w = (panel_w * panels.len().max(1) as u32).max(720);
    let entries = legend_entries(panels);
    let font = ("sans-serif", 14).into_font();
    let widths = entries
        .iter()
        .map(|(label, _)| font.box_size(label).map(|(tw, _)| tw))
        .collect::<Result<Vec<u32>, _>>()
        .map_err(|e| err(&e))?;
    let places = legend_layout(&widths, w);
    let rows = places.iter().map(|p| p.1 + 1).max().unwrap_or(0);
    let plots_h = 460u32;
    let h = plots_h + if rows == 0 { 0 } else { rows * LEGEND_ROW + 8 };
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (top, strip) = root.split_vertically(plots_h);
        let top = top.titled(title, ("sans-serif", 22)).map_err(|e| err(&e))?;
        let areas = top.split_evenly((1, panels.len().max(1)));
        for ((name, bands), area) in panels.iter().zip(areas) {
            let x_max = bands
                .iter()
                .flat_map(|b| b.points.iter().map(|p| p.0))
                .fold(1.0f64, f64::max);
            let mut chart = ChartBuilder::on(&area)
                .caption(name, ("sans-serif", 17))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(48)
                .build_cartesian_2d(0.0..x_max * 1.02, 0.0..1.0f64)
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .x_desc("frames")
                .x_label_formatter(&|x| format!("{:.1}M", x / 1e6))
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(|e| err(&e))?;
            for (i, b) in bands.iter().enumerate() {
                let color = series_color(i);
                let pts: Vec<&(f64, f64, f64, usize)> =
                    b.points.iter().filter(|p| p.1.is_finite()).collect();
                if pts.is_empty() {
                    // A model without this measure (a baseline's word accuracies): no line.
                    continue;
                }
                if pts.iter().any(|p| p.3 > 1) {
                    let mut poly: Vec<(f64, f64)> =
                        pts.iter().map(|p| (p.0, (p.1 + p.2).min(1.0))).collect();
                    poly.extend(pts.iter().rev().map(|p| (p.0, (p.1 - p.2).max(0.0))));
                    chart
                        .draw_series(std::iter::once(Polygon::new(poly, color.mix(0.2).filled())))
                        .map_err(|e| err(&e))?;
                }
                chart
                    .draw_series(LineSeries::new(
                        pts.iter().map(|p| (p.0, p.1)),
                        color.stroke_width(3),
                    ))
                    .map_err(|e| err(&e))?;
            }
        }
        for ((label, color), (x, row)) in entries.iter().zip(places) {
            let (x, y) = (x as i32, (row * LEGEND_ROW + LEGEND_ROW / 2) as i32);
            strip
                .draw(&PathElement::new(
                    vec![(x, y), (x + LEGEND_LINE as i32, y)],
                    color.stroke_width(3),
                ))
                .map_err(|e| err(&e))?;
            let text = Text::new(
                label.as_str(),
                (x + (LEGEND_LINE + LEGEND_PAD) as i32, y),
                font.color(&BLACK).pos(Pos::new(HPos::Left, VPos::Center)),
            );
            strip.draw(&text).map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    save_rgb(&buf, w, h, path)
}

/// One row of the legend strip, in pixels.
pub(crate) const LEGEND_ROW: u32 = 24;
/// The sample line of an entry, the space between it and its label, and between entries.
pub(crate) const LEGEND_LINE: u32 = 26;
pub(crate) const LEGEND_PAD: u32 = 6;
pub(crate) const LEGEND_GAP: u32 = 28;

/// The legend's entries: every label that has a line in some panel, once, in the order first
/// drawn, with its panel colour (bands are coloured by their place in the panel's list).
fn legend_entries(panels: &[(String, Vec<Band>)]) -> Vec<(String, RGBColor)> {
    let mut entries: Vec<(String, RGBColor)> = Vec::new();
    for (_, bands) in panels {
        for (i, b) in bands.iter().enumerate() {
            let drawn = b.points.iter().any(|p| p.1.is_finite());
            if drawn && !entries.iter().any(|(l, _)| *l == b.label) {
                entries.push((b.label.clone(), series_color(i)));
            }
        }
    }
    entries
}

/// Where each legend entry goes, given its label's width in pixels: `(x, row)`, entries left
/// to right in rows no wider than `width` (an entry wider than a row gets a row of its own),
/// each row centred.
pub(crate) fn legend_layout(label_widths: &[u32], width: u32) -> Vec<(u32, u32)> {
    let entry = |tw: u32| LEGEND_LINE + LEGEND_PAD + tw;
    let usable = width.saturating_sub(2 * LEGEND_GAP);
    // Rows as ranges of entries, with their widths.
    let mut rows: Vec<(usize, usize, u32)> = Vec::new();
    for (i, &tw) in label_widths.iter().enumerate() {
        match rows.last_mut() {
            Some((_, end, rw)) if *rw + LEGEND_GAP + entry(tw) <= usable => {
                *end = i + 1;
                *rw += LEGEND_GAP + entry(tw);
            }
            _ => rows.push((i, i + 1, entry(tw))),
        }
    }
    let mut places = Vec::with_capacity(label_widths.len());
    for (r, &(start, end, rw)) in rows.iter().enumerate() {
        let mut x = width.saturating_sub(rw) / 2;
        for &tw in &label_widths[start..end] {
            places.push((x, r as u32));
            x += entry(tw) + LEGEND_GAP;
        }
    }
    places
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::figures::SERIES_COLORS;

    #[test]
    fn legend_entries_fill_centred_rows_without_overlap() {
        let widths = [120, 300, 80, 400, 90];
        let places = legend_layout(&widths, 720);
        assert_eq!(places.len(), widths.len());
        let entry = |tw: u32| LEGEND_LINE + LEGEND_PAD + tw;
        // 120 + 300 + 80 fit in a row of 720 less the margins; 400 does not fit after them.
        let rows: Vec<u32> = places.iter().map(|p| p.1).collect();
        assert_eq!(rows, [0, 0, 0, 1, 1]);
        for (i, (&(x, r), &tw)) in places.iter().zip(&widths).enumerate() {
            assert!(x + entry(tw) <= 720, "entry {i} inside the figure");
            if let Some(&(nx, nr)) = places.get(i + 1)
                && nr == r
            {
                assert_eq!(
                    nx,
                    x + entry(tw) + LEGEND_GAP,
                    "entries {i}, {} apart",
                    i + 1
                );
            }
        }
        // Each row is centred: as much room on its left as on its right.
        let (x0, x2) = (places[0].0, places[2].0 + entry(widths[2]));
        assert!(x0.abs_diff(720 - x2) <= 1, "{x0} vs {}", 720 - x2);
        // A label wider than the figure still gets a place, alone on its row.
        assert_eq!(legend_layout(&[2000, 10], 720), [(0, 0), (339, 1)]);
        assert!(legend_layout(&[], 720).is_empty());
    }

    #[test]
    fn the_legend_lists_each_drawn_label_once_in_its_colour() {
        let line = |label: &str, y: f64| Band {
            label: label.into(),
            points: vec![(1.0, y, 0.0, 1)],
        };
        let panels = vec![
            ("a".to_owned(), vec![line("att", 0.5), line("base", 0.7)]),
            // The baseline has no word accuracies: a NaN line is not drawn.
            (
                "b".to_owned(),
                vec![line("att", 0.2), line("base", f64::NAN)],
            ),
            ("c".to_owned(), vec![line("x", f64::NAN), line("only", 0.1)]),
        ];
        let entries = legend_entries(&panels);
        let labels: Vec<&str> = entries.iter().map(|e| e.0.as_str()).collect();
        assert_eq!(labels, ["att", "base", "only"]);
        assert_eq!(entries[1].1, SERIES_COLORS[1]);
        assert_eq!(entries[2].1, SERIES_COLORS[1]);
    }

    #[test]
    fn recipes_drop_seed_suffixes_only() {
        assert_eq!(recipe_of("babyai-s2"), "babyai");
        assert_eq!(recipe_of("att_seed3"), "att");
        assert_eq!(recipe_of("x20-seed11"), "x20");
        assert_eq!(recipe_of("att-fast5M"), "att-fast5M");
        assert_eq!(recipe_of("runs-s"), "runs-s");
    }

    #[test]
    fn logs_find_their_run_name_and_tracked_evaluation() {
        use std::path::Path;
        let (name, ev) = run_files(Path::new("runs/att-s2/log.csv"));
        assert_eq!(
            (name.as_str(), ev.as_path()),
            ("att-s2", Path::new("runs/att-s2/eval_log.csv"))
        );
        let (name, ev) = run_files(Path::new("experiments/runs/attention_seed1_log.csv"));
        assert_eq!(name, "attention_seed1");
        assert_eq!(
            ev,
            Path::new("experiments/runs/attention_seed1_eval_log.csv")
        );
        assert_eq!(recipe_of(&name), "attention");
    }

    #[test]
    fn bands_average_within_bins_then_across_runs() {
        let a = vec![(1.0, 0.0), (2.0, 0.2), (3.0, 0.4), (4.0, 0.6)];
        let b = vec![(1.0, 1.0), (2.0, 1.0), (3.0, 1.0)];
        let band = band("r", &[a, b], 2);
        // Bin 1 (0, 2]: run a 0.1, run b 1.0; bin 2 (2, 4]: run a 0.5, run b 1.0.
        assert_eq!(band.points.len(), 2);
        let (x, m, s, n) = band.points[0];
        assert_eq!((x, n), (1.0, 2));
        assert!((m - 0.55).abs() < 1e-12 && (s - 0.45).abs() < 1e-12);
        let (_, m, s, n) = band.points[1];
        assert_eq!(n, 2);
        assert!((m - 0.75).abs() < 1e-12 && (s - 0.25).abs() < 1e-12);
    }

    #[test]
    fn empty_fields_read_as_nan_and_bad_ones_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("eval_log.csv");
        std::fs::write(&p, "frames,acc\n10,0.5\n20,\n").unwrap();
        let rows = read_columns(&p, &["frames", "acc"]).unwrap();
        assert_eq!(rows[0], vec![10.0, 0.5]);
        assert!(rows[1][1].is_nan());
        std::fs::write(&p, "frames,acc\n10,NaN\n20,0.5\n").unwrap();
        let rows = read_columns(&p, &["frames", "acc"]).unwrap();
        assert!(rows[0][1].is_nan() && rows[1] == vec![20.0, 0.5]);
        for bad in [
            "frames,acc\n,0.5\n",
            "frames,acc\nNaN,0.5\n",
            "frames,acc\n10,inf\n",
        ] {
            std::fs::write(&p, bad).unwrap();
            let e = read_columns(&p, &["frames", "acc"])
                .unwrap_err()
                .to_string();
            assert!(e.contains("line 2"), "{bad:?}: {e}");
        }
        std::fs::write(&p, "frames,acc\n10,x\n").unwrap();
        let e = read_columns(&p, &["frames", "acc"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2"), "{e}");
        let e = read_columns(&p, &["frames", "nope"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("nope"), "{e}");
    }

    #[test]
    fn panels_draw_a_band_for_several_runs() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("g.png");
        let runs: Vec<Vec<(f64, f64)>> = (0..3)
            .map(|k| {
                (1..=40)
                    .map(|i| (i as f64 * 1e5, 0.02 * i as f64 - 0.05 * k as f64 + 0.1))
                    .collect()
            })
            .collect();
        let b = band("recipe", &runs, 20);
        band_panels(&[("success".into(), vec![b])], "t", &p).unwrap();
        let img = image::open(&p).unwrap().to_rgb8();
        let (w, h) = img.dimensions();
        assert_eq!(w, 720, "one panel, widened for its title");
        assert_eq!(h, 460 + LEGEND_ROW + 8, "a row of legend below the panel");
        let c = SERIES_COLORS[0];
        let is_line = |px: &image::Rgb<u8>| px.0 == [c.0, c.1, c.2];
        assert!(
            img.enumerate_pixels()
                .any(|(_, y, px)| y < 460 && is_line(px)),
            "the mean line is drawn"
        );
        assert!(
            img.enumerate_pixels()
                .any(|(_, y, px)| y >= 460 && is_line(px)),
            "its legend entry is drawn below the panel"
        );
        // The band is the line colour at 20% over white.
        let shade = |v: u8| (f64::from(v) * 0.2 + 255.0 * 0.8).round() as u8;
        let tint = [shade(c.0), shade(c.1), shade(c.2)];
        let near = img
            .pixels()
            .filter(|px| px.0.iter().zip(tint).all(|(a, b)| a.abs_diff(b) <= 2))
            .count();
        assert!(near > 200, "the band is shaded ({near} px)");
    }
}
