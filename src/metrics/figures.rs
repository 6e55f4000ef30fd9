//! PNG figures with plotters: the learning curve (paper Fig. 4) and line plots with error
//! bars (Figs. 6–8). Text uses the bundled DejaVu Sans, so no system fonts are needed.

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;

use super::error::MetricsError;

static FONT: Once = Once::new();

/// The bundled font (Bitstream Vera licence, `assets/fonts/LICENSE-DejaVu.txt`).
const DEJAVU: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Makes the bundled font the `sans-serif` family (once).
pub fn register_font() {
    FONT.call_once(|| {
        // Registration fails only for an unparsable font, which the bundled one is not.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, DEJAVU);
    });
}

/// Distinct line colours: Okabe–Ito's colour-blind-friendly set (its yellow left out, too
/// pale on white), then black and three of Paul Tol's muted colours, so that the study's
/// figures of up to ten runs repeat none.
pub const SERIES_COLORS: [RGBColor; 10] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(136, 34, 85),
    RGBColor(153, 153, 51),
    RGBColor(119, 119, 119),
];

/// The colour of the `i`-th series of a figure (the palette repeats past its end), so that a
/// line and its legend entry are coloured by the same rule.
pub fn series_color(i: usize) -> RGBColor {
    SERIES_COLORS[i % SERIES_COLORS.len()]
}

fn plot_err(path: &Path, e: impl std::fmt::Display) -> MetricsError {
    MetricsError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// One curve: a label and its (x, y) points.
#[derive(Clone, Debug)]
pub struct Curve {
    /// Legend label.
    pub label: String,
    /// Points in x order.
    pub points: Vec<(f64, f64)>,
}

/// Trailing moving average over `window` points.
pub fn smooth(points: &[(f64, f64)], window: usize) -> Vec<(f64, f64)> {
    let w = window.max(1);
    points
        .iter()
        .enumerate()
        .map(|(i, &(x, _))| {
            let lo = i.saturating_sub(w - 1);
            let ys: Vec<f64> = points[lo..=i]
                .iter()
                .map(|p| p.1)
                .filter(|y| y.is_finite())
                .collect();
            let y = if ys.is_empty() {
                f64::NAN
            } else {
                ys.iter().sum::<f64>() / ys.len() as f64
            };
            (x, y)
        })
        .collect()
}

/// Writes a learning curve (mean reward against frames; raw values faint, a moving average
/// bold), one line per curve, to `path` atomically.
pub fn learning_curve(curves: &[Curve], title: &str, path: &Path) -> Result<(), MetricsError> {
    register_font();
    let (w, h) = (900u32, 520u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
        let x_max = curves
            .iter()
            .flat_map(|c| c.points.iter().map(|p| p.0))
            .fold(1.0f64, f64::max);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(56)
            .build_cartesian_2d(0.0..x_max * 1.02, 0.0..1.0f64)
            .map_err(|e| plot_err(path, e))?;
        chart
            .configure_mesh()
            .x_desc("frames")
            .y_desc("mean reward")
            .x_label_formatter(&|x| format!("{:.1}M", x / 1e6))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| plot_err(path, e))?;
        for (i, c) in curves.iter().enumerate() {
            let color = series_color(i);
            let raw: Vec<(f64, f64)> = c
                .points
                .iter()
                .copied()
                .filter(|p| p.1.is_finite())
                .collect();
            chart
                .draw_series(LineSeries::new(raw, color.mix(0.25).stroke_width(1)))
                .map_err(|e| plot_err(path, e))?;
            let smoothed: Vec<(f64, f64)> = smooth(&c.points, 20)
                .into_iter()
                .filter(|p| p.1.is_finite())
                .collect();
            chart
                .draw_series(LineSeries::new(smoothed, color.stroke_width(3)))
                .map_err(|e| plot_err(path, e))?
                .label(c.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(|e| plot_err(path, e))?;
        root.present().map_err(|e| plot_err(path, e))?;
    }
    save_rgb(&buf, w, h, path)
}

/// Saves an RGB buffer as PNG atomically.
pub fn save_rgb(buf: &[u8], w: u32, h: u32, path: &Path) -> Result<(), MetricsError> {
    let img = image::RgbImage::from_raw(w, h, buf.to_vec())
        .ok_or_else(|| plot_err(path, "bad image buffer"))?;
    crate::render::save_png(&img, path).map_err(|e| plot_err(path, e))
}

/// Reads `(frames, mean_reward)` from a training `log.csv`.
pub fn read_training_log(path: &Path) -> Result<Vec<(f64, f64)>, MetricsError> {
    let rows = super::bands::read_columns(path, &["frames", "mean_reward"])?;
    Ok(rows.iter().map(|r| (r[0], r[1])).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoothing_averages_a_trailing_window_and_skips_nan() {
        let pts = [(0.0, 1.0), (1.0, 3.0), (2.0, f64::NAN), (3.0, 5.0)];
        let s = smooth(&pts, 2);
        assert_eq!(s[0].1, 1.0);
        assert_eq!(s[1].1, 2.0);
        assert_eq!(s[2].1, 3.0);
        assert_eq!(s[3].1, 5.0);
    }

    #[test]
    fn learning_curve_writes_a_picture_with_both_lines() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("curve.png");
        let a = Curve {
            label: "attention".into(),
            points: (0..50).map(|i| (i as f64 * 1e5, i as f64 / 50.0)).collect(),
        };
        let b = Curve {
            label: "baseline".into(),
            points: (0..50).map(|i| (i as f64 * 1e5, 0.3)).collect(),
        };
        learning_curve(&[a, b], "Fig. 4", &path).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (900, 520));
        let has = |c: RGBColor| img.pixels().any(|p| p.0 == [c.0, c.1, c.2]);
        assert!(
            has(SERIES_COLORS[0]) && has(SERIES_COLORS[1]),
            "both series drawn"
        );
        let dark = img.pixels().filter(|p| p.0.iter().all(|&v| v < 60)).count();
        assert!(dark > 500, "axes and text drawn ({dark} dark pixels)");
    }
}
