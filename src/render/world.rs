//! The whole world, as `MiniGrid`'s `get_full_render` draws it: every cell's tile, the agent
//! on its cell, and (optionally) the cells it currently sees highlighted.

use image::{RgbImage, imageops};

use super::tiles::{TileCache, TileKey};
use crate::env::{Pos, VIEW_SIZE, World, world_from_view};

/// Top-left pixel of world cell `cell_in_world` in a render with `tile_size`-pixel tiles.
/// Coordinates below zero (outside the grid) clamp to 0.
pub fn px_in_image(cell_in_world: Pos, tile_size: u32) -> (u32, u32) {
    let px = |c: i32| u32::try_from(c).unwrap_or(0).saturating_mul(tile_size);
    (px(cell_in_world.0), px(cell_in_world.1))
}

/// The grid cells the agent sees now: the cells of its 7×7 view that lie inside the grid and
/// that its observation marks visible (`MiniGrid`'s `highlight_mask`), in view order.
pub fn visible_cells(world: &World) -> Vec<Pos> {
    let obs = world.observe();
    let mut cells = Vec::with_capacity(VIEW_SIZE * VIEW_SIZE);
    for vy in 0..VIEW_SIZE {
        for vx in 0..VIEW_SIZE {
            if !obs.visible((vx, vy)) {
                continue;
            }
            let pos = world_from_view(world.agent_pos, world.agent_dir, (vx, vy));
            if world.grid.contains(pos) {
                cells.push(pos);
            }
        }
    }
    cells
}

/// The full world, `width·tile_size` × `height·tile_size` pixels: each cell drawn by
/// [`render_tile`](super::render_tile), the agent's triangle on its cell, and with
/// `highlight_view` the cells it sees blended towards white, like `MiniGrid`'s
/// `get_full_render(highlight=True)`. The carried object is not drawn (`MiniGrid` does not).
pub fn render_world(world: &World, tile_size: u32, highlight_view: bool) -> RgbImage {
    let (w, h) = (world.grid.width(), world.grid.height());
    let mut lit = vec![false; w * h];
    if highlight_view {
        for (x, y) in visible_cells(world) {
            lit[x as usize * h + y as usize] = true;
        }
    }
    let mut img = RgbImage::new(
        (w as u32).saturating_mul(tile_size),
        (h as u32).saturating_mul(tile_size),
    );
    let mut cache = TileCache::new(tile_size);
    for x in 0..w {
        for y in 0..h {
            let pos = (x as i32, y as i32);
            let agent_dir = (pos == world.agent_pos).then_some(world.agent_dir);
            let key = TileKey::cell(world.grid.get(pos), agent_dir, lit[x * h + y]);
            let (px, py) = px_in_image(pos, tile_size);
            imageops::replace(&mut img, cache.get(key), i64::from(px), i64::from(py));
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::{Color, ObjectKind, WorldObj, view_from_world};
    use crate::render::fixtures;
    use crate::render::palette;
    use crate::render::tiles::render_tile;

    #[test]
    fn px_in_image_is_cell_times_tile() {
        assert_eq!(px_in_image((0, 0), 32), (0, 0));
        assert_eq!(px_in_image((3, 5), 32), (96, 160));
        assert_eq!(px_in_image((-1, 2), 10), (0, 20));
    }

    #[test]
    fn the_render_is_width_by_height_tiles() {
        let world = fixtures::world();
        let img = render_world(&world, 16, true);
        assert_eq!(img.dimensions(), (8 * 16, 8 * 16));
        let wide = fixtures::world_sized(10, 7);
        assert_eq!(render_world(&wide, 7, false).dimensions(), (70, 49));
        assert_eq!(render_world(&world, 0, true).dimensions(), (0, 0));
    }

    #[test]
    fn each_cell_is_its_tile() {
        let world = fixtures::world();
        let ts = 16;
        let img = render_world(&world, ts, false);
        for (pos, cell, dir) in [
            (
                (0, 0),
                Some(WorldObj::new(ObjectKind::Wall, Color::Grey, 0)),
                None,
            ),
            (
                fixtures::BALL,
                Some(WorldObj::new(ObjectKind::Ball, Color::Red, 0)),
                None,
            ),
            (fixtures::AGENT, None, Some(fixtures::AGENT_DIR)),
            ((2, 2), None, None),
        ] {
            let (px, py) = px_in_image(pos, ts);
            let got = imageops::crop_imm(&img, px, py, ts, ts).to_image();
            assert_eq!(got, render_tile(cell, dir, false, ts), "cell {pos:?}");
        }
    }

    #[test]
    fn visible_cells_are_the_view_cells_the_observation_sees() {
        let world = fixtures::world();
        let obs = world.observe();
        let mut expected = Vec::new();
        for x in 0..8 {
            for y in 0..8 {
                if let Some(v) = view_from_world(world.agent_pos, world.agent_dir, (x, y))
                    && obs.visible(v)
                {
                    expected.push((x, y));
                }
            }
        }
        let mut got = visible_cells(&world);
        got.sort_unstable();
        assert_eq!(got, expected);
        // The agent faces up from (3, 5): row 6 behind it is out of view, row 0 is in.
        assert!(got.contains(&(3, 0)) && got.contains(&(3, 4)));
        assert!(!got.iter().any(|&(_, y)| y == 6));
    }

    #[test]
    fn seen_cells_are_brighter_than_unseen_floor() {
        let world = fixtures::world();
        let ts = 16;
        let img = render_world(&world, ts, true);
        let centre = |pos| {
            let (px, py) = px_in_image(pos, ts);
            img.get_pixel(px + ts / 2, py + ts / 2).0
        };
        let seen = centre((2, 3));
        let behind = centre((2, 6));
        assert_eq!(behind, palette::BACKGROUND);
        assert_eq!(seen, palette::highlight(palette::BACKGROUND));
        assert!(seen.iter().zip(behind).all(|(s, b)| *s > b));
        // Without highlighting the same cell is plain floor.
        let plain = render_world(&world, ts, false);
        let (px, py) = px_in_image((2, 3), ts);
        assert_eq!(
            plain.get_pixel(px + ts / 2, py + ts / 2).0,
            palette::BACKGROUND
        );
    }
}
