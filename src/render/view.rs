//! The agent's 7×7 view, agent-up, drawn from its observation encoding alone (`MiniGrid`'s
//! `get_pov_render`, except that cells the agent did not see are blank: the encoding has
//! nothing to draw there).

use image::{RgbImage, imageops};

use super::tiles::{TileCache, TileKey};
use crate::env::{AGENT_IN_VIEW, Color, DoorState, ObjectKind, Observation, VIEW_SIZE, WorldObj};

/// The object an encoded view cell `(type, colour, state)` shows: `None` when the cell was
/// not seen (type 0, or a type `MiniGrid` does not have), `Some(None)` for a seen empty cell.
/// Unknown colours read as grey and unknown door states as closed; object ids are 0.
pub fn decode_view_cell(enc: [u8; 3]) -> Option<Option<WorldObj>> {
    let [kind, color, state] = enc;
    let kind = ObjectKind::from_index(kind)?;
    match kind {
        ObjectKind::Unseen => None,
        // The agent never appears in its own partial view; nothing else to draw there.
        ObjectKind::Empty | ObjectKind::Agent => Some(None),
        _ => {
            let state = match (kind, state) {
                (ObjectKind::Door, 2) => DoorState::Locked,
                (ObjectKind::Door, 1 | 3..) => DoorState::Closed,
                _ => DoorState::Open,
            };
            Some(Some(WorldObj {
                kind,
                color: Color::from_index(color).unwrap_or(Color::Grey),
                state,
                id: 0,
            }))
        }
    }
}

/// The view as the agent sees it, `7·tile_size` pixels square: image row = `vy` (row 0
/// farthest ahead), column = `vx`, the agent at the bottom middle `(3, 6)` as a triangle
/// pointing up with its carried object, if any, small in the corner of its tile. Seen cells
/// are highlighted as in `MiniGrid`'s POV render; unseen cells stay black.
pub fn render_view(obs: &Observation, tile_size: u32) -> RgbImage {
    let side = (VIEW_SIZE as u32).saturating_mul(tile_size);
    let mut img = RgbImage::new(side, side);
    let mut cache = TileCache::new(tile_size);
    for vy in 0..VIEW_SIZE {
        for vx in 0..VIEW_SIZE {
            let seen = decode_view_cell(obs.at((vx, vy)));
            let key = if (vx, vy) == AGENT_IN_VIEW {
                TileKey::agent(seen.flatten(), 3, seen.is_some())
            } else {
                match seen {
                    Some(cell) => TileKey::cell(cell, None, true),
                    None => TileKey::unseen(),
                }
            };
            let (px, py) = (
                vx as i64 * i64::from(tile_size),
                vy as i64 * i64::from(tile_size),
            );
            imageops::replace(&mut img, cache.get(key), px, py);
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::fixtures;
    use crate::render::palette;
    use crate::render::tiles::{render_agent_tile, render_tile};

    fn tile(img: &RgbImage, (vx, vy): (u32, u32), ts: u32) -> RgbImage {
        imageops::crop_imm(img, vx * ts, vy * ts, ts, ts).to_image()
    }

    #[test]
    fn decoding_follows_minigrid_indices() {
        assert_eq!(decode_view_cell([0, 0, 0]), None);
        assert_eq!(decode_view_cell([1, 0, 0]), Some(None));
        assert_eq!(decode_view_cell([42, 0, 0]), None);
        let ball = decode_view_cell([6, 2, 0]).flatten();
        assert_eq!(
            ball.map(|o| (o.kind, o.color)),
            Some((ObjectKind::Ball, Color::Blue))
        );
        for (state, want) in [
            (0, DoorState::Open),
            (1, DoorState::Closed),
            (2, DoorState::Locked),
        ] {
            let door = decode_view_cell([4, 4, state]).flatten();
            assert_eq!(door.map(|o| o.state), Some(want));
        }
    }

    #[test]
    fn the_view_is_agent_up_with_rows_as_vy() {
        let world = fixtures::world();
        let obs = world.observe();
        let ts = 16;
        let img = render_view(&obs, ts);
        assert_eq!(img.dimensions(), (7 * ts, 7 * ts));
        // The agent at (3, 5) facing up sees the ball at (5, 2) at vx = 5, vy = 3.
        let ball = WorldObj::new(ObjectKind::Ball, Color::Red, 0);
        assert_eq!(
            tile(&img, (5, 3), ts),
            render_tile(Some(ball), None, true, ts)
        );
        assert_eq!(tile(&img, (3, 6), ts), render_agent_tile(None, 3, true, ts));
        // The wall row y = 0 is view row 1; behind it, row 0 is unseen and stays dark.
        let wall = WorldObj::new(ObjectKind::Wall, Color::Grey, 0);
        assert_eq!(
            tile(&img, (3, 1), ts),
            render_tile(Some(wall), None, true, ts)
        );
        let unseen = tile(&img, (3, 0), ts);
        assert_eq!(unseen.get_pixel(ts / 2, ts / 2).0, palette::UNSEEN);
        // Hatched, so that it reads neither as floor nor as the panel behind the picture.
        assert!(
            unseen
                .pixels()
                .any(|p| p.0[2] >= palette::UNSEEN_HATCH[2] / 2)
        );
        let floor = tile(&img, (3, 4), ts);
        assert!(floor.get_pixel(ts / 2, ts / 2).0[0] > unseen.get_pixel(ts / 2, ts / 2).0[0]);
    }

    #[test]
    fn the_carried_object_is_drawn_in_the_agent_tile() {
        let mut world = fixtures::world();
        let key = WorldObj::new(ObjectKind::Key, Color::Yellow, 99);
        world.carrying = Some(key);
        let ts = 32;
        let img = render_view(&world.observe(), ts);
        let agent = tile(&img, (3, 6), ts);
        assert_eq!(agent, render_agent_tile(Some(key), 3, true, ts));
        assert_ne!(agent, render_agent_tile(None, 3, true, ts));
    }

    #[test]
    fn an_all_unseen_observation_renders_without_panicking() {
        let obs = Observation {
            image: [[[0; 3]; VIEW_SIZE]; VIEW_SIZE],
        };
        let img = render_view(&obs, 8);
        assert_eq!(img.dimensions(), (56, 56));
        assert_eq!(render_view(&obs, 0).dimensions(), (0, 0));
    }
}
