//! Marks drawn over a world render: an attention map that tints the floor and only rings the
//! cells that hold something (so an object keeps its true colour and colour words can be
//! checked by eye), the mission's targets outlined, the cells a word names circled by whether
//! its map falls on them, and the agent's trail.

use image::RgbImage;

use super::heatmap::{ViewMap, clamp_alpha, colorize, mix};
use super::palette::{self, Rgb};
use super::world::px_in_image;
use crate::env::{Pos, World, world_from_view};

/// How a view map is drawn on a world cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellMark {
    /// Empty floor: the whole tile is blended with the map's colour.
    Tint,
    /// An object, wall or the agent: only a ring at the tile's edge takes the map's colour,
    /// the inside keeps its own colours.
    Ring,
    /// A door: its colour is all in its frame (the tile's outer eighth), so the ring sits
    /// just inside the frame, on the door's dark panel, and the door keeps its colour.
    Inset,
}

/// Width in pixels of the ring drawn on occupied cells: an eighth of the tile, at least 1.
/// Public, as the sizes below are, so that a page that draws these marks itself (the HTML
/// episode page) draws them as wide as every other display.
pub fn ring_px(tile_size: u32) -> u32 {
    (tile_size / 8).max(1)
}

/// Length in pixels of each arm of a target's corner brackets ([`outline_targets`]).
pub fn target_arm_px(tile_size: u32) -> u32 {
    (tile_size / 3).max(1)
}

/// Half the side, in pixels, of the trail's dot ([`draw_trail`]): the dot covers the pixels
/// closer than this to the tile's centre.
pub fn trail_half_px(tile_size: u32) -> u32 {
    (tile_size / 10).max(1)
}

/// Opacity of the trail's dot.
pub const TRAIL_ALPHA: f32 = 0.8;

/// The world cells a view map covers, each with its value and how it is drawn, in view
/// order; view cells outside the grid are left out.
pub fn map_cells(world: &World, map: &ViewMap) -> Vec<(Pos, f32, CellMark)> {
    let mut out = Vec::with_capacity(49);
    for (vy, row) in map.iter().enumerate() {
        for (vx, &value) in row.iter().enumerate() {
            let pos = world_from_view(world.agent_pos, world.agent_dir, (vx, vy));
            if !world.grid.contains(pos) {
                continue;
            }
            let mark = match world.grid.get(pos) {
                None if pos != world.agent_pos => CellMark::Tint,
                Some(o) if o.kind == crate::env::ObjectKind::Door => CellMark::Inset,
                _ => CellMark::Ring,
            };
            out.push((pos, value, mark));
        }
    }
    out
}

/// Blends `color` with weight `alpha` over the pixels of cell `pos` for which `inside(dx, dy)`
/// holds (offsets within the tile); pixels outside the image are skipped.
fn paint_cell(
    img: &mut RgbImage,
    pos: Pos,
    tile_size: u32,
    color: Rgb,
    alpha: f32,
    inside: impl Fn(u32, u32) -> bool,
) {
    let (img_w, img_h) = img.dimensions();
    let (x0, y0) = px_in_image(pos, tile_size);
    for dy in 0..tile_size {
        for dx in 0..tile_size {
            let (x, y) = (x0 + dx, y0 + dy);
            if x >= img_w || y >= img_h || !inside(dx, dy) {
                continue;
            }
            let p = img.get_pixel_mut(x, y);
            for (c, o) in p.0.iter_mut().zip(color) {
                *c = mix(*c, o, alpha);
            }
        }
    }
}

/// Whether offset `(dx, dy)` of a tile lies in its edge band `width` pixels wide.
fn on_edge(dx: u32, dy: u32, tile_size: u32, width: u32) -> bool {
    dx < width || dy < width || dx + width >= tile_size || dy + width >= tile_size
}

/// Whether offset `(dx, dy)` lies in the band `width` pixels wide just inside a tile's outer
/// band of the same width (a door's frame).
fn in_inset(dx: u32, dy: u32, tile_size: u32, width: u32) -> bool {
    let inner = |d: u32| d >= width && d + width < tile_size;
    inner(dx) && inner(dy) && on_edge(dx - width, dy - width, tile_size - 2 * width, width)
}

/// Draws a view map over a world render made with the same `tile_size`: empty floor cells
/// are blended with the map's viridis colour on `lo..=hi` (weight `alpha`, clamped to
/// `[0, 1]`); cells holding an object, wall or door, and the agent's own cell, get the
/// colour only on a ring [`ring_px`] wide at full strength, so their contents keep their
/// true colours. Cells outside the grid or the image are skipped.
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
    let ring = ring_px(tile_size);
    for (pos, value, mark) in map_cells(world, map) {
        let color = colorize(value, lo, hi);
        match mark {
            CellMark::Tint => paint_cell(world_img, pos, tile_size, color, alpha, |_, _| true),
            CellMark::Ring => paint_cell(world_img, pos, tile_size, color, 1.0, |dx, dy| {
                on_edge(dx, dy, tile_size, ring)
            }),
            CellMark::Inset => paint_cell(world_img, pos, tile_size, color, 1.0, |dx, dy| {
                in_inset(dx, dy, tile_size, ring)
            }),
        }
    }
}

/// Marks each cell of `cells` with [`palette::TARGET`] brackets at its four corners, in the
/// edge band [`ring_px`] wide: objects leave only that band free (a ball's edge or a box's
/// frame starts just inside it), so the corners take the target's colour and the rest of
/// the band keeps the attention ring's.
pub fn outline_targets(img: &mut RgbImage, cells: &[Pos], tile_size: u32) {
    let ring = ring_px(tile_size);
    let arm = target_arm_px(tile_size);
    let near_end = |d: u32| d < arm || d + arm >= tile_size;
    for &pos in cells {
        paint_cell(img, pos, tile_size, palette::TARGET, 1.0, |dx, dy| {
            on_edge(dx, dy, tile_size, ring) && near_end(dx) && near_end(dy)
        });
    }
}

/// Circles each cell of `marks` in its colour, as the 7×7 maps circle a word's related
/// objects (white: the map passes τ on the cell; orange: only next to it; red: a miss): a ring
/// of radius 0.42 of the tile, round a ball or a key rather than over it, edged in black on
/// both sides so that it reads on any tile, orange on lava included.
pub fn ring_referents(img: &mut RgbImage, marks: &[(Pos, Rgb)], tile_size: u32) {
    let t = tile_size as f32;
    let (radius, half, edge) = (0.42 * t, (0.07 * t).max(0.75), (0.06 * t).max(0.5));
    let off_ring = |dx: u32, dy: u32| {
        let (x, y) = (dx as f32 + 0.5 - t / 2.0, dy as f32 + 0.5 - t / 2.0);
        // Not `hypot`: glibc's `hypotf` is versioned 2.35, past the Python wheel's
        // manylinux_2_34.
        ((x * x + y * y).sqrt() - radius).abs()
    };
    for &(pos, color) in marks {
        paint_cell(img, pos, tile_size, palette::BACKGROUND, 1.0, |dx, dy| {
            off_ring(dx, dy) <= half + edge
        });
        paint_cell(img, pos, tile_size, color, 1.0, |dx, dy| {
            off_ring(dx, dy) <= half
        });
    }
}

/// Marks every cell of `trail` (the agent's earlier cells) with a small square of
/// [`palette::TRAIL`] at its centre.
pub fn draw_trail(img: &mut RgbImage, trail: &[Pos], tile_size: u32) {
    let half = trail_half_px(tile_size);
    let mid = tile_size / 2;
    for &pos in trail {
        paint_cell(
            img,
            pos,
            tile_size,
            palette::TRAIL,
            TRAIL_ALPHA,
            |dx, dy| dx.abs_diff(mid) < half && dy.abs_diff(mid) < half,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::{VIEW_SIZE, view_from_world};
    use crate::render::{fixtures, render_world};

    #[test]
    fn floor_is_tinted_and_occupied_cells_keep_their_inside() {
        let world = fixtures::world();
        let ts = 16;
        let plain = render_world(&world, ts, true);
        let mut img = plain.clone();
        let map = [[1.0; VIEW_SIZE]; VIEW_SIZE];
        overlay_on_world(&mut img, &world, &map, ts, 0.6, 0.0, 1.0);
        let yellow = colorize(1.0, 0.0, 1.0);
        let ring = ring_px(ts);
        for (pos, _, mark) in map_cells(&world, &map) {
            let (x0, y0) = px_in_image(pos, ts);
            for dy in 0..ts {
                for dx in 0..ts {
                    let (was, got) = (
                        plain.get_pixel(x0 + dx, y0 + dy),
                        img.get_pixel(x0 + dx, y0 + dy),
                    );
                    match mark {
                        CellMark::Tint => assert_ne!(was, got, "floor {pos:?} is tinted"),
                        CellMark::Ring if on_edge(dx, dy, ts, ring) => {
                            assert_eq!(got.0, yellow, "{pos:?} ring");
                        }
                        CellMark::Ring => assert_eq!(was, got, "{pos:?} inside keeps its colours"),
                        CellMark::Inset => {}
                    }
                }
            }
        }
        // The red ball's cell holds its palette red (highlighted: the agent sees it) at the
        // centre, overlay or not.
        let (bx, by) = px_in_image(fixtures::BALL, ts);
        assert_eq!(
            img.get_pixel(bx + ts / 2, by + ts / 2).0,
            palette::highlight(palette::object(crate::env::Color::Red))
        );
        let marks: Vec<_> = map_cells(&world, &map)
            .into_iter()
            .map(|(p, _, m)| (p, m))
            .collect();
        assert!(marks.contains(&(fixtures::BALL, CellMark::Ring)));
        assert!(marks.contains(&(fixtures::AGENT, CellMark::Ring)));
        assert!(marks.contains(&((2, 3), CellMark::Tint)));
        assert!(
            marks.contains(&((0, 3), CellMark::Ring)),
            "a wall is ringed"
        );
    }

    /// A closed door keeps its colour under the map: its frame (the tile's outer band, where
    /// all its colour is) is left alone and the map's ring sits just inside it.
    #[test]
    fn a_door_keeps_its_frame_and_the_ring_sits_inside_it() {
        let mut world = fixtures::world();
        let door = (2, 3);
        let mut d =
            crate::env::WorldObj::new(crate::env::ObjectKind::Door, crate::env::Color::Red, 90);
        d.state = crate::env::DoorState::Closed;
        world.grid.set(door, Some(d));
        let ts = 16;
        let plain = render_world(&world, ts, false);
        let mut img = plain.clone();
        let map = [[1.0; VIEW_SIZE]; VIEW_SIZE];
        overlay_on_world(&mut img, &world, &map, ts, 0.6, 0.0, 1.0);
        let marks: Vec<_> = map_cells(&world, &map)
            .into_iter()
            .map(|(p, _, m)| (p, m))
            .collect();
        assert!(marks.contains(&(door, CellMark::Inset)), "{marks:?}");
        let yellow = colorize(1.0, 0.0, 1.0);
        let ring = ring_px(ts);
        let (x0, y0) = px_in_image(door, ts);
        let mut frame_red = 0;
        for dy in 0..ts {
            for dx in 0..ts {
                let (was, got) = (
                    plain.get_pixel(x0 + dx, y0 + dy),
                    img.get_pixel(x0 + dx, y0 + dy),
                );
                if on_edge(dx, dy, ts, ring) {
                    assert_eq!(was, got, "the frame at ({dx}, {dy}) is untouched");
                    let [r, g, b] = got.0.map(i32::from);
                    frame_red += usize::from(r > g + 60 && r > b + 60);
                } else if in_inset(dx, dy, ts, ring) {
                    assert_eq!(got.0, yellow, "the ring at ({dx}, {dy})");
                } else {
                    assert_eq!(was, got, "the inside at ({dx}, {dy})");
                }
            }
        }
        assert!(frame_red > 0, "the door's colour is in its frame");
    }

    #[test]
    fn cells_outside_the_view_grid_or_image_are_left_alone() {
        let world = fixtures::world();
        let ts = 8;
        let plain = render_world(&world, ts, false);
        let mut img = plain.clone();
        overlay_on_world(
            &mut img,
            &world,
            &[[1.0; VIEW_SIZE]; VIEW_SIZE],
            ts,
            0.5,
            0.0,
            1.0,
        );
        for (x, y, p) in img.enumerate_pixels() {
            let cell = ((x / ts) as i32, (y / ts) as i32);
            if view_from_world(world.agent_pos, world.agent_dir, cell).is_none() {
                assert_eq!(p, plain.get_pixel(x, y), "({x}, {y}) lies outside the view");
            }
        }
        // The top view row lies at y = −1: 7 × 6 cells inside the grid.
        assert_eq!(map_cells(&world, &[[0.0; VIEW_SIZE]; VIEW_SIZE]).len(), 42);
        let mut small = RgbImage::new(20, 10);
        overlay_on_world(
            &mut small,
            &world,
            &[[1.0; VIEW_SIZE]; VIEW_SIZE],
            ts,
            0.5,
            0.0,
            1.0,
        );
        assert_eq!(small.dimensions(), (20, 10));
    }

    /// A referent's circle takes its colour on the ring and black just beside it; the
    /// tile's centre and corners (where a ball's middle and the target's corners are) keep
    /// theirs, and a cell not marked is left alone.
    #[test]
    fn referents_are_circled_in_their_colour_around_the_middle() {
        let world = fixtures::world();
        let ts = 16;
        let plain = render_world(&world, ts, false);
        let mut img = plain.clone();
        ring_referents(&mut img, &[(fixtures::BALL, palette::GROUNDING_MISS)], ts);
        let (bx, by) = px_in_image(fixtures::BALL, ts);
        let at = |img: &RgbImage, dx: u32, dy: u32| img.get_pixel(bx + dx, by + dy).0;
        // On the ring: left, right, top and bottom of the centre, 0.42 of the tile away.
        for (dx, dy) in [(1, 8), (14, 8), (8, 1), (8, 14)] {
            assert_eq!(at(&img, dx, dy), palette::GROUNDING_MISS, "({dx}, {dy})");
        }
        // Just inside the ring, black; the ball's middle and the tile's corners unchanged.
        assert_eq!(at(&img, 2, 8), palette::BACKGROUND);
        for (dx, dy) in [(8, 8), (7, 7), (0, 0), (15, 15)] {
            assert_eq!(at(&img, dx, dy), at(&plain, dx, dy), "({dx}, {dy})");
        }
        let (ox, oy) = px_in_image((2, 3), ts);
        for dy in 0..ts {
            for dx in 0..ts {
                assert_eq!(
                    img.get_pixel(ox + dx, oy + dy),
                    plain.get_pixel(ox + dx, oy + dy)
                );
            }
        }
    }

    #[test]
    fn targets_are_outlined_and_the_trail_is_dotted() {
        let world = fixtures::world();
        let ts = 16;
        let mut img = render_world(&world, ts, false);
        outline_targets(&mut img, &[fixtures::BALL], ts);
        let (bx, by) = px_in_image(fixtures::BALL, ts);
        // Its corners are magenta; the middle of its edges and its inside are not.
        for (dx, dy) in [
            (0, 0),
            (ts - 1, 0),
            (0, ts - 1),
            (ts - 1, ts - 1),
            (3, 0),
            (0, 3),
        ] {
            assert_eq!(
                img.get_pixel(bx + dx, by + dy).0,
                palette::TARGET,
                "({dx}, {dy})"
            );
        }
        for (dx, dy) in [
            (ts / 2, 0),
            (0, ts / 2),
            (ts / 2, ts / 2),
            (ring_px(ts), ring_px(ts)),
        ] {
            assert_ne!(
                img.get_pixel(bx + dx, by + dy).0,
                palette::TARGET,
                "({dx}, {dy})"
            );
        }
        draw_trail(&mut img, &[(2, 4)], ts);
        let (tx, ty) = px_in_image((2, 4), ts);
        assert_ne!(
            img.get_pixel(tx + ts / 2, ty + ts / 2).0,
            palette::BACKGROUND
        );
        assert_eq!(img.get_pixel(tx + 3, ty + 3).0, palette::BACKGROUND);
    }
}
