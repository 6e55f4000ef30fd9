//! Heat maps of per-view-cell values (attention weights, saliency): the viridis colour map, a
//! 7×7 map drawn agent-up, a colour bar, and alpha blending (the projection onto the world render
//! is in [`super::overlay`]).

use image::RgbImage;

use super::RenderError;
use super::palette::{self, Rgb};
use crate::env::VIEW_SIZE;

/// A value per view cell, `map[vy][vx]`: row `vy` (0 = farthest ahead), column `vx`, the
/// agent at `map[6][3]`, i.e. the view as displayed agent-up.
pub type ViewMap = [[f32; VIEW_SIZE]; VIEW_SIZE];

/// Viridis at `t ∈ [0, 1]` (clamped; NaN reads as 0), picked from the 256-entry table the
/// way matplotlib's `ListedColormap` picks: entry `⌊256·t⌋`, with `t = 1` the last entry.
pub fn viridis(t: f32) -> Rgb {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let last = palette::VIRIDIS.len() - 1;
    let i = ((t * palette::VIRIDIS.len() as f32) as usize).min(last);
    palette::VIRIDIS[i]
}

/// The viridis colour of `value` on the scale `lo..=hi`: `lo` and below are dark purple,
/// `hi` and above are yellow. With `hi <= lo` every value at or above `hi` is yellow and
/// the rest purple; NaN is purple.
pub fn colorize(value: f32, lo: f32, hi: f32) -> Rgb {
    let t = if value >= hi {
        1.0
    } else if value <= lo {
        0.0
    } else {
        (value - lo) / (hi - lo)
    };
    viridis(t)
}

/// A view map as a `7·cell_px` square image, one flat cell per view cell, agent-up (image
/// row = `vy`, column = `vx`).
pub fn render_heatmap(map: &ViewMap, cell_px: u32, lo: f32, hi: f32) -> RgbImage {
    let side = (VIEW_SIZE as u32).saturating_mul(cell_px);
    RgbImage::from_fn(side, side, |x, y| {
        let (vx, vy) = ((x / cell_px) as usize, (y / cell_px) as usize);
        image::Rgb(colorize(map[vy][vx], lo, hi))
    })
}

/// A vertical colour bar for the scale `lo..=hi`: `hi` (yellow) on the top row, `lo`
/// (purple) on the bottom row, linear in between, every column alike.
pub fn colorbar(height: u32, width: u32, lo: f32, hi: f32) -> RgbImage {
    let span = height.saturating_sub(1).max(1) as f32;
    RgbImage::from_fn(width, height, |_, y| {
        let t = 1.0 - y as f32 / span;
        // The end rows get the end values exactly, whatever the float rounding in between.
        let value = match y {
            0 => hi,
            _ if y + 1 == height => lo,
            _ => lo + t * (hi - lo),
        };
        image::Rgb(colorize(value, lo, hi))
    })
}

/// One channel of `base` moved a fraction `alpha` of the way to `over`, rounded.
#[inline]
pub(super) fn mix(base: u8, over: u8, alpha: f32) -> u8 {
    let (b, o) = (f32::from(base), f32::from(over));
    (b + (o - b) * alpha).round().clamp(0.0, 255.0) as u8
}

/// `alpha` clamped to `[0, 1]`, NaN read as 0 (leave the base as it is).
pub(super) fn clamp_alpha(alpha: f32) -> f32 {
    if alpha.is_nan() {
        0.0
    } else {
        alpha.clamp(0.0, 1.0)
    }
}

/// Blends `overlay` over `base` in place: `base + (overlay − base)·alpha`, `alpha` clamped
/// to `[0, 1]`. Images of different sizes are an error and leave `base` untouched.
pub fn blend(base: &mut RgbImage, overlay: &RgbImage, alpha: f32) -> Result<(), RenderError> {
    if base.dimensions() != overlay.dimensions() {
        return Err(RenderError::SizeMismatch {
            base: base.dimensions(),
            overlay: overlay.dimensions(),
        });
    }
    let alpha = clamp_alpha(alpha);
    for (b, o) in base.iter_mut().zip(overlay.iter()) {
        *b = mix(*b, *o, alpha);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::palette::luminance;

    fn close(a: Rgb, b: Rgb, tol: u8) -> bool {
        a.iter().zip(b).all(|(x, y)| x.abs_diff(y) <= tol)
    }

    #[test]
    fn viridis_matches_matplotlib_at_known_points() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        // matplotlib: viridis(0.25) = #3b528b, viridis(0.5) = #21918c, viridis(0.75) = #5ec962.
        assert!(
            close(viridis(0.25), [0x3b, 0x52, 0x8b], 2),
            "{:?}",
            viridis(0.25)
        );
        assert!(
            close(viridis(0.5), [0x21, 0x91, 0x8c], 2),
            "{:?}",
            viridis(0.5)
        );
        assert!(
            close(viridis(0.75), [0x5e, 0xc9, 0x62], 2),
            "{:?}",
            viridis(0.75)
        );
        assert_eq!(viridis(-3.0), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(f32::NAN), viridis(0.0));
    }

    #[test]
    fn viridis_luminance_rises_from_dark_to_light() {
        let table = palette::VIRIDIS;
        for i in 2..table.len() {
            let (before, now) = (luminance(table[i - 2]), luminance(table[i]));
            assert!(now > before, "entry {i}: {now} <= {before}");
        }
        // Adjacent entries may only dip by rounding to 8 bits.
        for i in 1..table.len() {
            assert!(
                luminance(table[i]) > luminance(table[i - 1]) - 1e-3,
                "entry {i}"
            );
        }
    }

    #[test]
    fn colorize_maps_the_range_onto_the_table() {
        assert_eq!(colorize(-1.0, -1.0, 3.0), palette::VIRIDIS[0]);
        assert_eq!(colorize(3.0, -1.0, 3.0), palette::VIRIDIS[255]);
        assert_eq!(colorize(1.0, -1.0, 3.0), palette::VIRIDIS[128]);
        assert_eq!(colorize(9.0, 0.0, 1.0), palette::VIRIDIS[255]);
        assert_eq!(colorize(f32::NAN, 0.0, 1.0), palette::VIRIDIS[0]);
        // A degenerate scale splits at hi instead of dividing by zero.
        assert_eq!(colorize(0.5, 0.5, 0.5), palette::VIRIDIS[255]);
        assert_eq!(colorize(0.4, 0.5, 0.5), palette::VIRIDIS[0]);
    }

    #[test]
    fn the_heatmap_puts_each_value_at_its_view_cell() {
        let mut map = [[0.0; VIEW_SIZE]; VIEW_SIZE];
        map[1][5] = 1.0; // vy = 1, vx = 5
        map[4][0] = 0.5;
        let cell = 6;
        let img = render_heatmap(&map, cell, 0.0, 1.0);
        assert_eq!(img.dimensions(), (42, 42));
        let at = |vx: u32, vy: u32| img.get_pixel(vx * cell + cell / 2, vy * cell + cell / 2).0;
        assert_eq!(at(5, 1), colorize(1.0, 0.0, 1.0));
        assert_eq!(
            *img.get_pixel(5 * cell, cell),
            image::Rgb(colorize(1.0, 0.0, 1.0))
        );
        assert_eq!(at(1, 5), colorize(0.0, 0.0, 1.0), "transposed map");
        assert_eq!(at(0, 4), colorize(0.5, 0.0, 1.0));
        assert_eq!(at(3, 6), colorize(0.0, 0.0, 1.0));
    }

    #[test]
    fn the_colorbar_runs_from_hi_at_the_top_to_lo_at_the_bottom() {
        let bar = colorbar(100, 12, 2.0, 4.0);
        assert_eq!(bar.dimensions(), (12, 100));
        assert_eq!(bar.get_pixel(0, 0).0, colorize(4.0, 2.0, 4.0));
        assert_eq!(bar.get_pixel(11, 99).0, colorize(2.0, 2.0, 4.0));
        let lum: Vec<f64> = (0..100).map(|y| luminance(bar.get_pixel(5, y).0)).collect();
        assert!(lum[0] > lum[50] && lum[50] > lum[99]);
        assert!((0..100).all(|y| bar.get_pixel(0, y) == bar.get_pixel(11, y)));
        assert_eq!(colorbar(0, 5, 0.0, 1.0).dimensions(), (5, 0));
        assert_eq!(
            colorbar(1, 1, 0.0, 1.0).get_pixel(0, 0).0,
            colorize(1.0, 0.0, 1.0)
        );
    }

    #[test]
    fn blend_mixes_by_alpha_and_refuses_other_sizes() {
        let mut base = RgbImage::from_pixel(3, 2, image::Rgb([0, 100, 200]));
        let over = RgbImage::from_pixel(3, 2, image::Rgb([200, 100, 0]));
        blend(&mut base, &over, 0.25).unwrap();
        assert!(base.pixels().all(|p| p.0 == [50, 100, 150]));
        let before = base.clone();
        let wrong = RgbImage::new(2, 3);
        assert!(matches!(
            blend(&mut base, &wrong, 0.5),
            Err(RenderError::SizeMismatch { .. })
        ));
        assert_eq!(base, before);
        blend(&mut base, &over, 5.0).unwrap();
        assert_eq!(base, over);
        blend(&mut base, &before, f32::NAN).unwrap();
        assert_eq!(base, over);
    }
}
