//! The faithfulness figures: deletion/insertion curves, the per-step ρ distribution against
//! its permuted control, and closed-loop and counterfactual success beside the unmodified run.

use std::path::Path;

use plotters::prelude::*;

use super::report::{CheckpointFaithfulness, RHO_BINS};
use crate::metrics::MetricsError;
use crate::metrics::figures::{SERIES_COLORS, register_font, save_rgb};

fn err(path: &Path, e: impl std::fmt::Display) -> MetricsError {
    MetricsError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

const W: u32 = 1000;
const H: u32 = 460;

/// Deletion (left) and insertion (right) curves of one checkpoint: the chosen action's
/// probability, relative to the unperturbed one, as objects are removed or put back in M
/// order, random order and Δ order.
pub fn deletion_curves(c: &CheckpointFaithfulness, path: &Path) -> Result<(), MetricsError> {
    register_font();
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(path, e))?;
        let panels = root.split_evenly((1, 2));
        for (panel, (name, aucs)) in panels
            .iter()
            .zip([("deletion", &c.deletion), ("insertion", &c.insertion)])
        {
            let y_max = aucs
                .curves
                .values()
                .flatten()
                .fold(1.2f64, |a, b| a.max(*b + 0.05));
            let mut chart = ChartBuilder::on(panel)
                .caption(format!("{name} ({})", c.variant), ("sans-serif", 20))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(52)
                .build_cartesian_2d(0.0..1.0f64, 0.0..y_max)
                .map_err(|e| err(path, e))?;
            chart
                .configure_mesh()
                .x_desc(format!(
                    "fraction of visible objects {}",
                    if name == "deletion" {
                        "removed"
                    } else {
                        "inserted"
                    }
                ))
                .y_desc("p(action) / unperturbed")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(|e| err(path, e))?;
            for (i, (key, label)) in [
                ("by_m", "M order"),
                ("random", "random order"),
                ("oracle", "Δ order (oracle)"),
            ]
            .iter()
            .enumerate()
            {
                let Some(curve) = aucs.curves.get(key) else {
                    continue;
                };
                let n = (curve.len().max(2) - 1) as f64;
                let pts: Vec<(f64, f64)> = curve
                    .iter()
                    .enumerate()
                    .map(|(k, y)| (k as f64 / n, *y))
                    .collect();
                let color = SERIES_COLORS[i];
                chart
                    .draw_series(LineSeries::new(pts, color.stroke_width(3)))
                    .map_err(|e| err(path, e))?
                    .label(*label)
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
                    });
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(|e| err(path, e))?;
        }
        root.present().map_err(|e| err(path, e))?;
    }
    save_rgb(&buf, W, H, path)
}

/// Histogram of the per-step Spearman ρ(M, Δ) beside the same for a permuted M.
pub fn rho_distribution(c: &CheckpointFaithfulness, path: &Path) -> Result<(), MetricsError> {
    register_font();
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(path, e))?;
        let y_max = c
            .rho_histogram
            .values()
            .flatten()
            .copied()
            .max()
            .unwrap_or(1)
            .max(1) as f64
            * 1.1;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("per-step Spearman ρ(M, occlusion Δ), {}", c.checkpoint),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(52)
            .build_cartesian_2d(-1.0..1.0f64, 0.0..y_max)
            .map_err(|e| err(path, e))?;
        chart
            .configure_mesh()
            .x_desc("ρ")
            .y_desc("steps")
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|e| err(path, e))?;
        let width = 2.0 / RHO_BINS as f64;
        for (i, (key, label)) in [("measured", "M"), ("permuted", "permuted M (control)")]
            .iter()
            .enumerate()
        {
            let Some(bins) = c.rho_histogram.get(key) else {
                continue;
            };
            let color = SERIES_COLORS[i];
            // The two series side by side inside each bin.
            let half = width / 2.0;
            chart
                .draw_series(bins.iter().enumerate().map(|(b, n)| {
                    let x0 = -1.0 + b as f64 * width + i as f64 * half;
                    Rectangle::new([(x0, 0.0), (x0 + half * 0.9, *n as f64)], color.filled())
                }))
                .map_err(|e| err(path, e))?
                .label(*label)
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 16, y + 5)], color.filled())
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| err(path, e))?;
        root.present().map_err(|e| err(path, e))?;
    }
    save_rgb(&buf, W, H, path)
}

/// A bar's label.
fn short(name: &str) -> &str {
    match name {
        "uniform" => "M uniform",
        "steered" => "M steered",
        "color_word_zero" => "colour word w=0",
        "object_word_zero" => "object word w=0",
        "recolor_target" => "recolour target",
        "move_target" => "move target",
        "add_twin" => "add a twin",
        "mission_color_to_distractor" => "mission names distractor",
        other => other,
    }
}

/// Success of closed-loop re-runs and counterfactual episodes (bars) beside the unmodified
/// episodes' success (dark ticks).
pub fn effects(c: &CheckpointFaithfulness, path: &Path) -> Result<(), MetricsError> {
    register_font();
    let mut bars: Vec<(String, f64, f64)> = Vec::new();
    let none = c
        .closed_loop
        .get("none")
        .and_then(|n| n.success.mean)
        .or(c.success.mean)
        .unwrap_or(0.0);
    for (name, l) in &c.closed_loop {
        if *name != "none" {
            bars.push((short(name).to_owned(), l.success.mean.unwrap_or(0.0), none));
        }
    }
    for (name, cf) in &c.counterfactuals {
        if let (Some(v), Some(base)) = (cf.success.value.mean, cf.success.control.mean) {
            bars.push((short(name).to_owned(), v, base));
        }
    }
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(path, e))?;
        let n = bars.len().max(1);
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "success under interventions and counterfactuals, {}",
                    c.checkpoint
                ),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(90)
            .y_label_area_size(52)
            .build_cartesian_2d(0.0..n as f64, 0.0..1.3f64)
            .map_err(|e| err(path, e))?;
        let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n * 2 + 1)
            .x_label_formatter(&|x| {
                let i = x.floor() as usize;
                if (x - i as f64 - 0.5).abs() < 0.26 {
                    names.get(i).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_desc("success rate")
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(|e| err(path, e))?;
        chart
            .draw_series(bars.iter().enumerate().map(|(i, b)| {
                Rectangle::new(
                    [(i as f64 + 0.2, 0.0), (i as f64 + 0.8, b.1)],
                    SERIES_COLORS[0].filled(),
                )
            }))
            .map_err(|e| err(path, e))?
            .label("with the change")
            .legend(|(x, y)| {
                Rectangle::new([(x, y - 5), (x + 16, y + 5)], SERIES_COLORS[0].filled())
            });
        chart
            .draw_series(bars.iter().enumerate().map(|(i, b)| {
                PathElement::new(
                    vec![(i as f64 + 0.1, b.2), (i as f64 + 0.9, b.2)],
                    BLACK.stroke_width(3),
                )
            }))
            .map_err(|e| err(path, e))?
            .label("unmodified episodes")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], BLACK.stroke_width(3)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| err(path, e))?;
        root.present().map_err(|e| err(path, e))?;
    }
    save_rgb(&buf, W, H, path)
}
