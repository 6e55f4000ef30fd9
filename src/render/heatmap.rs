//! Heat maps of per-view-cell values (attention weights, saliency): the viridis colour map, a
//! 7×7 map drawn agent-up, a colour bar, alpha blending, and the projection of a view map onto
//! the world render.

use image::RgbImage;

use super::RenderError;
use super::palette::{self, Rgb};
use super::world::px_in_image;
use crate::env::{VIEW_SIZE, World, world_from_view};

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
fn mix(base: u8, over: u8, alpha: f32) -> u8 {
    let (b, o) = (f32::from(base), f32::from(over));
    (b + (o - b) * alpha).round().clamp(0.0, 255.0) as u8
}

/// `alpha` clamped to `[0, 1]`, NaN read as 0 (leave the base as it is).
fn clamp_alpha(alpha: f32) -> f32 {
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

/// Projects a view map onto a world render (as [`render_world`](super::render_world) draws
/// it with the same `tile_size`): each view cell's colour is blended with weight `alpha`
/// over the tile of the world cell it shows, `world_from_view(agent_pos, agent_dir, (vx,
/// vy))`. View cells outside the grid, and pixels outside `world_img`, are skipped.
pub fn overlay_on_world(
    world_img: &mut RgbImage,
    world: &World,
    map: &ViewMap,
    tile_size: u32,
    alpha: f32,
    lo: f32,
    hi: f32,
) {
    let alpha = clamp_alpha(alpha);
    let (img_w, img_h) = world_img.dimensions();
    for (vy, row) in map.iter().enumerate() {
        for (vx, &value) in row.iter().enumerate() {
            let pos = world_from_view(world.agent_pos, world.agent_dir, (vx, vy));
            if !world.grid.contains(pos) {
                continue;
            }
            let color = colorize(value, lo, hi);
            let (x0, y0) = px_in_image(pos, tile_size);
            let x1 = x0.saturating_add(tile_size).min(img_w);
            let y1 = y0.saturating_add(tile_size).min(img_h);
            for y in y0..y1 {
                for x in x0..x1 {
                    let p = world_img.get_pixel_mut(x, y);
                    for (c, o) in p.0.iter_mut().zip(color) {
                        *c = mix(*c, o, alpha);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::view_from_world;
    use crate::render::{fixtures, render_world};

    /// Relative luminance of an sRGB colour (Rec. 709 weights on linear light).
    fn luminance(c: Rgb) -> f64 {
        let lin = |v: u8| {
            let v = f64::from(v) / 255.0;
            if v <= 0.040_45 {
                v / 12.92
            } else {
                ((v + 0.055) / 1.055).powf(2.4)
            }
        };
        0.2126 * lin(c[0]) + 0.7152 * lin(c[1]) + 0.0722 * lin(c[2])
    }

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

    #[test]
    fn the_overlay_lands_on_the_cell_in_front_of_the_agent() {
        let world = fixtures::world();
        let ts = 16;
        let plain = render_world(&world, ts, false);
        let mut img = plain.clone();
        let mut map = [[0.0; VIEW_SIZE]; VIEW_SIZE];
        map[5][3] = 1.0; // vy = 5, vx = 3: one step ahead
        overlay_on_world(&mut img, &world, &map, ts, 1.0, 0.0, 1.0);
        let front = world_from_view(world.agent_pos, world.agent_dir, (3, 5));
        assert_eq!(front, world.front_pos());
        let (px, py) = px_in_image(front, ts);
        assert_eq!(img.get_pixel(px + 3, py + 3).0, colorize(1.0, 0.0, 1.0));
        // The agent's own cell got the low colour; the row behind it is untouched.
        let (ax, ay) = px_in_image(world.agent_pos, ts);
        assert_eq!(img.get_pixel(ax + 1, ay + 1).0, colorize(0.0, 0.0, 1.0));
        let (bx, by) = px_in_image((3, 6), ts);
        assert_eq!(
            img.get_pixel(bx + 5, by + 5),
            plain.get_pixel(bx + 5, by + 5)
        );
    }

    #[test]
    fn the_overlay_skips_what_lies_outside_grid_or_image() {
        let world = fixtures::world();
        let map = [[1.0; VIEW_SIZE]; VIEW_SIZE];
        let yellow = colorize(1.0, 0.0, 1.0);
        // Half-way between a channel and yellow's, rounded as `blend` rounds.
        let half = |p: image::Rgb<u8>| {
            image::Rgb(std::array::from_fn(|c| {
                f32::midpoint(f32::from(p.0[c]), f32::from(yellow[c])).round() as u8
            }))
        };
        let seen = |x: u32, y: u32, ts: u32| {
            let cell = ((x / ts) as i32, (y / ts) as i32);
            view_from_world(world.agent_pos, world.agent_dir, cell).is_some()
        };
        // The agent at (3, 5) facing up sees columns 0..=6 and rows −1..=5: the top view
        // row lies at y = −1, outside the grid, and is skipped (not drawn on row 0 again);
        // column 7 and rows 6 and 7 are behind or beside the view and keep the world.
        let ts = 8;
        let plain = render_world(&world, ts, false);
        let mut img = plain.clone();
        overlay_on_world(&mut img, &world, &map, ts, 0.5, 0.0, 1.0);
        assert_eq!(img.dimensions(), plain.dimensions());
        let mut covered = std::collections::BTreeSet::new();
        for (x, y, p) in img.enumerate_pixels() {
            let was = *plain.get_pixel(x, y);
            if seen(x, y, ts) {
                covered.insert((x / ts, y / ts));
                assert_eq!(*p, half(was), "({x}, {y}) lies in the view");
            } else {
                assert_eq!(*p, was, "({x}, {y}) lies outside the view");
            }
        }
        assert_eq!(covered.len(), 7 * 6, "the view's cells inside the grid");
        // An image smaller than the world: what it holds of the view is blended, the rest
        // (column 7 from x = 56) kept, and nothing is drawn past its edges.
        let grey = image::Rgb([100, 100, 100]);
        let mut small = RgbImage::from_pixel(60, 10, grey);
        overlay_on_world(&mut small, &world, &map, ts, 0.5, 0.0, 1.0);
        assert_eq!(small.dimensions(), (60, 10));
        for (x, y, p) in small.enumerate_pixels() {
            let want = if x < 56 { half(grey) } else { grey };
            assert_eq!(*p, want, "({x}, {y})");
        }
        let mut empty = RgbImage::new(0, 0);
        overlay_on_world(&mut empty, &world, &map, ts, 0.5, 0.0, 1.0);
        assert_eq!(empty.dimensions(), (0, 0));
    }
}
