//! The tiles an episode page draws its world and view with: every distinct tile the episode
//! shows, drawn once by the renderer every other display uses ([`render_tile`],
//! [`render_agent_tile`], the view's unseen tile) into one PNG, and named by index in the
//! page's data. The browser then lays tiles out by index: the pictures are MiniGrid's to the
//! pixel, yet a step costs a few hundred small numbers instead of two images.

use std::collections::HashMap;

use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder as _, RgbImage, imageops};

use super::hex;
use crate::env::{Color, DoorState, ObjectKind, Observation, VIEW_SIZE, WorldObj};
use crate::record::RecordError;
use crate::render::{render_agent_tile, render_tile, render_view};

/// Tiles per row of the atlas image.
pub(super) const ATLAS_COLUMNS: usize = 16;

/// What an object looks like: its identity does not change its tile.
type Look = (ObjectKind, Color, DoorState);

/// An object's [`Look`]; a door's state is the only state a tile shows.
fn look(o: WorldObj) -> Look {
    let state = if o.kind == ObjectKind::Door {
        o.state
    } else {
        DoorState::Open
    };
    (o.kind, o.color, state)
}

/// An object that looks like `l` (its id is never drawn).
fn object((kind, color, state): Look) -> WorldObj {
    WorldObj {
        kind,
        color,
        state,
        id: 0,
    }
}

/// One tile of the atlas.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Tile {
    /// A world cell: what it holds, the agent on it facing `agent`, and whether the agent sees
    /// it now (blended towards white, as `MiniGrid` highlights it).
    Cell {
        /// The cell's object.
        obj: Option<Look>,
        /// The agent's direction, when it stands here.
        agent: Option<u8>,
        /// Seen now.
        lit: bool,
    },
    /// The agent's own cell in its view: the agent facing up with what it carries.
    ViewAgent {
        /// The carried object.
        carried: Option<Look>,
        /// Whether the observation saw the cell.
        lit: bool,
    },
    /// A view cell the agent did not see (hatched).
    Unseen,
}

impl Tile {
    /// A world or view cell holding `cell`, with the agent on it facing `agent`.
    pub(super) fn cell(cell: Option<WorldObj>, agent: Option<u8>, lit: bool) -> Self {
        Self::Cell {
            obj: cell.map(look),
            agent: agent.map(|d| d & 3),
            lit,
        }
    }

    /// The agent's cell in its view.
    pub(super) fn view_agent(carried: Option<WorldObj>, lit: bool) -> Self {
        Self::ViewAgent {
            carried: carried.map(look),
            lit,
        }
    }

    /// What the page's maps outline at a view cell showing this tile, as the debugger's maps
    /// do: `"u"` unseen (hatched), `"w"` a wall, an object's colour, or `""` for nothing.
    fn landmark(self) -> String {
        match self {
            Self::Unseen => "u".to_owned(),
            Self::Cell {
                obj: Some((ObjectKind::Wall, ..)),
                agent: None,
                ..
            } => "w".to_owned(),
            Self::Cell {
                obj: Some((_, color, _)),
                agent: None,
                ..
            } => hex(color.rgb()),
            _ => String::new(),
        }
    }
}

/// The tiles used so far, each with its index.
#[derive(Debug, Default)]
pub(super) struct Atlas {
    index: HashMap<Tile, usize>,
    tiles: Vec<Tile>,
}

impl Atlas {
    /// The index of `tile`, added if it is new.
    pub(super) fn id(&mut self, tile: Tile) -> usize {
        if let Some(&i) = self.index.get(&tile) {
            return i;
        }
        let i = self.tiles.len();
        self.tiles.push(tile);
        self.index.insert(tile, i);
        i
    }

    /// The index of each tile of `obs`'s view, row by row (`vy`, then `vx`), drawn as
    /// [`render_view`] draws them.
    pub(super) fn view(&mut self, obs: &Observation) -> Vec<usize> {
        let mut out = Vec::with_capacity(VIEW_SIZE * VIEW_SIZE);
        for vy in 0..VIEW_SIZE {
            for vx in 0..VIEW_SIZE {
                let seen = crate::render::decode_view_cell(obs.at((vx, vy)));
                let tile = if (vx, vy) == crate::env::AGENT_IN_VIEW {
                    Tile::view_agent(seen.flatten(), seen.is_some())
                } else {
                    match seen {
                        Some(cell) => Tile::cell(cell, None, true),
                        None => Tile::Unseen,
                    }
                };
                out.push(self.id(tile));
            }
        }
        out
    }

    /// Each tile's landmark for the maps ([`Tile::landmark`]), by index.
    pub(super) fn landmarks(&self) -> Vec<String> {
        self.tiles.iter().map(|t| t.landmark()).collect()
    }

    /// The atlas as a PNG: tile `i` at column `i % ATLAS_COLUMNS`, row `i / ATLAS_COLUMNS`,
    /// each `tile_px` square.
    pub(super) fn png(&self, tile_px: u32) -> Result<Vec<u8>, RecordError> {
        let rows = self.tiles.len().div_ceil(ATLAS_COLUMNS).max(1);
        let mut img = RgbImage::new(ATLAS_COLUMNS as u32 * tile_px, rows as u32 * tile_px);
        // The view's unseen tile is only drawn inside a view: an observation that saw nothing.
        let unseen = render_view(
            &Observation {
                image: [[[0; 3]; VIEW_SIZE]; VIEW_SIZE],
            },
            tile_px,
        );
        let unseen = imageops::crop_imm(&unseen, 0, 0, tile_px, tile_px).to_image();
        for (i, tile) in self.tiles.iter().enumerate() {
            let drawn = match *tile {
                Tile::Cell { obj, agent, lit } => render_tile(obj.map(object), agent, lit, tile_px),
                Tile::ViewAgent { carried, lit } => {
                    render_agent_tile(carried.map(object), 3, lit, tile_px)
                }
                Tile::Unseen => unseen.clone(),
            };
            let (x, y) = (i % ATLAS_COLUMNS, i / ATLAS_COLUMNS);
            imageops::replace(
                &mut img,
                &drawn,
                (x as u32 * tile_px).into(),
                (y as u32 * tile_px).into(),
            );
        }
        let mut bytes = Vec::new();
        PngEncoder::new_with_quality(&mut bytes, CompressionType::Best, FilterType::Adaptive)
            .write_image(
                img.as_raw(),
                img.width(),
                img.height(),
                ExtendedColorType::Rgb8,
            )
            .map_err(|e| RecordError::Encode(e.to_string()))?;
        Ok(bytes)
    }
}
