//! One tile, drawn the way `MiniGrid`'s `Grid.render_tile` and the objects' `render` methods
//! draw it: shapes are filled on a canvas supersampled [`SUBDIVS`]× along each axis, then every
//! block of sub-pixels is averaged into one pixel, which antialiases the edges.
//!
//! Shape tests use `MiniGrid`'s exact predicates (sub-pixel centres `(i + 0.5) / side`, closed
//! rectangles and circles, half-open triangles) so that tiles match `MiniGrid`'s pixel for pixel
//! up to float rounding.

use std::collections::HashMap;
use std::f64::consts::FRAC_PI_2;

use image::RgbImage;

use super::palette::{self, Rgb};
use crate::env::{Color, DoorState, ObjectKind, WorldObj};

/// Sub-pixels per pixel along each axis (`MiniGrid`'s `subdivs`).
pub const SUBDIVS: u32 = 3;

/// The agent's triangle pointing right (direction 0), in tile units. `MiniGrid` stores the
/// corners as `float32`; keeping that rounding keeps edge pixels identical.
const AGENT_TRIANGLE: [(f32, f32); 3] = [(0.12, 0.19), (0.87, 0.50), (0.12, 0.81)];

/// Thickness of the grid line on a tile's top and left edge, in tile units.
const GRID_LINE_WIDTH: f64 = 0.031;

/// Where the view render puts a carried object inside the agent's tile: the top-right
/// corner, the one area the up-pointing triangle leaves free, so the object stays readable
/// even when it has the agent's colour.
const CARRIED_FRAME: Frame = Frame {
    x0: 0.55,
    y0: 0.0,
    scale: 0.45,
};

/// An object's unit square placed inside the tile: tile = `origin + scale · object`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Frame {
    x0: f64,
    y0: f64,
    scale: f64,
}

impl Frame {
    const UNIT: Self = Self {
        x0: 0.0,
        y0: 0.0,
        scale: 1.0,
    };
}

/// The supersampled canvas of one tile.
struct Canvas {
    side: usize,
    /// Centre of sub-pixel row or column `i` in tile units, computed once as `MiniGrid` does.
    centres: Vec<f64>,
    px: Vec<Rgb>,
    frame: Frame,
}

impl Canvas {
    fn new(tile_size: u32) -> Self {
        let side = (tile_size * SUBDIVS) as usize;
        let n = side as f64;
        Self {
            side,
            centres: (0..side).map(|i| (i as f64 + 0.5) / n).collect(),
            px: vec![palette::BACKGROUND; side * side],
            frame: Frame::UNIT,
        }
    }

    /// Sub-pixel indices whose centres may fall in `[lo, hi]` (frame units along one axis),
    /// one sub-pixel wider on each side than needed: the predicate has the last word.
    fn span(&self, lo: f64, hi: f64, origin: f64) -> std::ops::Range<usize> {
        let n = self.side as f64;
        let (a, b) = (
            origin + self.frame.scale * lo,
            origin + self.frame.scale * hi,
        );
        let start = (a * n - 1.5).floor().clamp(0.0, n) as usize;
        let end = (b * n + 0.5).ceil().clamp(0.0, n) as usize;
        start..end.max(start)
    }

    /// Paints `color` on every sub-pixel whose centre, in frame units, satisfies `inside`;
    /// only sub-pixels within `[xmin, xmax] × [ymin, ymax]` are tested.
    fn fill(&mut self, bbox: [f64; 4], color: Rgb, inside: impl Fn(f64, f64) -> bool) {
        let [xmin, xmax, ymin, ymax] = bbox;
        let f = self.frame;
        let xs = self.span(xmin, xmax, f.x0);
        let ys = self.span(ymin, ymax, f.y0);
        for sy in ys {
            let y = (self.centres[sy] - f.y0) / f.scale;
            let row = sy * self.side;
            for sx in xs.clone() {
                let x = (self.centres[sx] - f.x0) / f.scale;
                if inside(x, y) {
                    self.px[row + sx] = color;
                }
            }
        }
    }

    /// `point_in_rect`: a closed rectangle.
    fn rect(&mut self, xmin: f64, xmax: f64, ymin: f64, ymax: f64, color: Rgb) {
        self.fill([xmin, xmax, ymin, ymax], color, |x, y| {
            x >= xmin && x <= xmax && y >= ymin && y <= ymax
        });
    }

    /// `point_in_circle`: a closed disc.
    fn circle(&mut self, cx: f64, cy: f64, r: f64, color: Rgb) {
        self.fill([cx - r, cx + r, cy - r, cy + r], color, |x, y| {
            (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r
        });
    }

    /// `point_in_line`: a segment of half-width `r` with round caps; `MiniGrid` keeps the end
    /// points and the direction in `float32`.
    fn line(&mut self, p0: (f64, f64), p1: (f64, f64), r: f64, color: Rgb) {
        let (x0, y0) = (p0.0 as f32, p0.1 as f32);
        let (dx, dy) = (p1.0 as f32 - x0, p1.1 as f32 - y0);
        let dist = (dx * dx + dy * dy).sqrt();
        if dist <= 0.0 {
            self.circle(p0.0, p0.1, r, color);
            return;
        }
        let (ux, uy) = (f64::from(dx / dist), f64::from(dy / dist));
        let (x0, y0, dist) = (f64::from(x0), f64::from(y0), f64::from(dist));
        let bbox = [
            p0.0.min(p1.0) - r,
            p0.0.max(p1.0) + r,
            p0.1.min(p1.1) - r,
            p0.1.max(p1.1) + r,
        ];
        self.fill(bbox, color, |x, y| {
            if x < bbox[0] || x > bbox[1] || y < bbox[2] || y > bbox[3] {
                return false;
            }
            let a = ((x - x0) * ux + (y - y0) * uy).clamp(0.0, dist);
            let (px, py) = (x0 + a * ux, y0 + a * uy);
            ((x - px) * (x - px) + (y - py) * (y - py)).sqrt() <= r
        });
    }

    /// The agent's triangle rotated by 90°·`dir` about the tile centre (`rotate_fn` around
    /// `point_in_triangle`): the query point is rotated back, as `MiniGrid` does.
    fn agent(&mut self, dir: u8, color: Rgb) {
        let theta = FRAC_PI_2 * f64::from(dir & 3);
        let (cos, sin) = ((-theta).cos(), (-theta).sin());
        let [a, b, c] = AGENT_TRIANGLE.map(|(x, y)| (f64::from(x), f64::from(y)));
        let (v0, v1) = ((c.0 - a.0, c.1 - a.1), (b.0 - a.0, b.1 - a.1));
        let dot00 = v0.0 * v0.0 + v0.1 * v0.1;
        let dot01 = v0.0 * v1.0 + v0.1 * v1.1;
        let dot11 = v1.0 * v1.0 + v1.1 * v1.1;
        let inv_denom = 1.0 / (dot00 * dot11 - dot01 * dot01);
        // Bounding box of the turned triangle: the corners mapped by the inverse rotation.
        let turned = [a, b, c].map(|(x, y)| {
            let (x, y) = (x - 0.5, y - 0.5);
            (0.5 + x * cos + y * sin, 0.5 - x * sin + y * cos)
        });
        let bbox = [
            turned.iter().map(|p| p.0).fold(f64::INFINITY, f64::min),
            turned.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max),
            turned.iter().map(|p| p.1).fold(f64::INFINITY, f64::min),
            turned.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max),
        ];
        self.fill(bbox, color, |x, y| {
            let (x, y) = (x - 0.5, y - 0.5);
            let (x, y) = (0.5 + x * cos - y * sin, 0.5 + y * cos + x * sin);
            let v2 = (x - a.0, y - a.1);
            let dot02 = v0.0 * v2.0 + v0.1 * v2.1;
            let dot12 = v1.0 * v2.0 + v1.1 * v2.1;
            let u = (dot11 * dot02 - dot01 * dot12) * inv_denom;
            let v = (dot00 * dot12 - dot01 * dot02) * inv_denom;
            u >= 0.0 && v >= 0.0 && u + v < 1.0
        });
    }

    /// The object's `render` method.
    fn object(&mut self, obj: WorldObj) {
        let c = palette::object(obj.color);
        match obj.kind {
            ObjectKind::Wall | ObjectKind::Goal => self.rect(0.0, 1.0, 0.0, 1.0, c),
            ObjectKind::Floor => {
                let shade = palette::scaled(c, palette::FLOOR_SHADE);
                self.rect(GRID_LINE_WIDTH, 1.0, GRID_LINE_WIDTH, 1.0, shade);
            }
            ObjectKind::Lava => self.lava(),
            ObjectKind::Door => self.door(obj.state, c),
            ObjectKind::Key => {
                self.rect(0.50, 0.63, 0.31, 0.88, c);
                self.rect(0.38, 0.50, 0.59, 0.66, c);
                self.rect(0.38, 0.50, 0.81, 0.88, c);
                self.circle(0.56, 0.28, 0.190, c);
                self.circle(0.56, 0.28, 0.064, palette::BACKGROUND);
            }
            ObjectKind::Ball => self.circle(0.5, 0.5, 0.31, c),
            ObjectKind::Box => {
                self.rect(0.12, 0.88, 0.12, 0.88, c);
                self.rect(0.18, 0.82, 0.18, 0.82, palette::BACKGROUND);
                self.rect(0.16, 0.84, 0.47, 0.53, c);
            }
            // Never stored in a grid or carried: nothing to draw.
            ObjectKind::Unseen | ObjectKind::Empty | ObjectKind::Agent => {}
        }
    }

    fn door(&mut self, state: DoorState, c: Rgb) {
        match state {
            DoorState::Open => {
                self.rect(0.88, 1.00, 0.00, 1.00, c);
                self.rect(0.92, 0.96, 0.04, 0.96, palette::BACKGROUND);
            }
            DoorState::Locked => {
                self.rect(0.00, 1.00, 0.00, 1.00, c);
                let panel = palette::scaled(c, palette::LOCKED_DOOR_SHADE);
                self.rect(0.06, 0.94, 0.06, 0.94, panel);
                self.rect(0.52, 0.75, 0.50, 0.56, c);
            }
            DoorState::Closed => {
                self.rect(0.00, 1.00, 0.00, 1.00, c);
                self.rect(0.04, 0.96, 0.04, 0.96, palette::BACKGROUND);
                self.rect(0.08, 0.92, 0.08, 0.92, c);
                self.rect(0.12, 0.88, 0.12, 0.88, palette::BACKGROUND);
                self.circle(0.75, 0.50, 0.08, c);
            }
        }
    }

    fn lava(&mut self) {
        self.rect(0.0, 1.0, 0.0, 1.0, palette::LAVA);
        let r = 0.03;
        for i in 0..3 {
            let ylo = 0.3 + 0.2 * f64::from(i);
            let yhi = 0.4 + 0.2 * f64::from(i);
            self.line((0.1, ylo), (0.3, yhi), r, palette::BACKGROUND);
            self.line((0.3, yhi), (0.5, ylo), r, palette::BACKGROUND);
            self.line((0.5, ylo), (0.7, yhi), r, palette::BACKGROUND);
            self.line((0.7, yhi), (0.9, ylo), r, palette::BACKGROUND);
        }
    }

    /// `highlight_img` (optional) then `downsample`. The average is taken as numpy takes it
    /// (mean over a row's sub-pixels, then over the rows) and truncated as the assignment into
    /// `MiniGrid`'s `uint8` frame truncates.
    fn into_image(mut self, highlight: bool) -> RgbImage {
        if highlight {
            // A table per channel: 256 blends instead of one per sub-pixel.
            let lut: [Rgb; 256] = std::array::from_fn(|v| palette::highlight([v as u8; 3]));
            for p in &mut self.px {
                *p = [
                    lut[usize::from(p[0])][0],
                    lut[usize::from(p[1])][1],
                    lut[usize::from(p[2])][2],
                ];
            }
        }
        let k = SUBDIVS as usize;
        let tile = self.side / k;
        let mut img = RgbImage::new(tile as u32, tile as u32);
        for (i, out) in img.pixels_mut().enumerate() {
            let (tx, ty) = (i % tile, i / tile);
            for ch in 0..3 {
                let mut rows = 0.0;
                for sy in 0..k {
                    let start = (ty * k + sy) * self.side + tx * k;
                    let sum: f64 = self.px[start..start + k]
                        .iter()
                        .map(|p| f64::from(p[ch]))
                        .sum();
                    rows += sum / k as f64;
                }
                out.0[ch] = (rows / k as f64) as u8;
            }
        }
        img
    }
}

/// What one tile shows; equal keys give equal tiles (object identities do not matter).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) struct TileKey {
    cell: Option<(ObjectKind, Color, DoorState)>,
    carried: Option<(ObjectKind, Color, DoorState)>,
    agent_dir: Option<u8>,
    highlight: bool,
    unseen: bool,
}

fn look(obj: WorldObj) -> (ObjectKind, Color, DoorState) {
    let state = if obj.kind == ObjectKind::Door {
        obj.state
    } else {
        DoorState::Open
    };
    (obj.kind, obj.color, state)
}

impl TileKey {
    /// A world cell, with the agent on it facing `agent_dir` if given.
    pub(super) fn cell(cell: Option<WorldObj>, agent_dir: Option<u8>, highlight: bool) -> Self {
        Self {
            cell: cell.map(look),
            carried: None,
            agent_dir: agent_dir.map(|d| d & 3),
            highlight,
            unseen: false,
        }
    }

    /// The agent's own cell in its view: what it carries (drawn small) under its triangle.
    pub(super) fn agent(carrying: Option<WorldObj>, agent_dir: u8, highlight: bool) -> Self {
        Self {
            cell: None,
            carried: carrying.map(look),
            agent_dir: Some(agent_dir & 3),
            highlight,
            unseen: false,
        }
    }

    /// A view cell the agent did not see.
    pub(super) fn unseen() -> Self {
        Self {
            cell: None,
            carried: None,
            agent_dir: None,
            highlight: false,
            unseen: true,
        }
    }

    fn draw(self, tile_size: u32) -> RgbImage {
        let obj = |(kind, color, state)| WorldObj {
            kind,
            color,
            state,
            id: 0,
        };
        let mut canvas = Canvas::new(tile_size);
        if self.unseen {
            canvas.rect(0.0, 1.0, 0.0, 1.0, palette::UNSEEN);
            // Two diagonals off the centre, as the maps hatch their unseen cells.
            for t in [1.0 / 3.0, 2.0 / 3.0] {
                canvas.line((0.0, t), (t, 0.0), 0.04, palette::UNSEEN_HATCH);
                canvas.line((1.0 - t, 1.0), (1.0, 1.0 - t), 0.04, palette::UNSEEN_HATCH);
            }
        }
        canvas.rect(0.0, GRID_LINE_WIDTH, 0.0, 1.0, palette::GRID_LINE);
        canvas.rect(0.0, 1.0, 0.0, GRID_LINE_WIDTH, palette::GRID_LINE);
        if let Some(cell) = self.cell {
            canvas.object(obj(cell));
        }
        if let Some(carried) = self.carried {
            canvas.frame = CARRIED_FRAME;
            canvas.object(obj(carried));
            canvas.frame = Frame::UNIT;
        }
        if let Some(dir) = self.agent_dir {
            canvas.agent(dir, palette::AGENT);
        }
        canvas.into_image(self.highlight)
    }
}

/// Tiles drawn during one render, reused across the cells that look alike (walls, floor);
/// it lives only as long as that render.
pub(super) struct TileCache {
    tile_size: u32,
    tiles: HashMap<TileKey, RgbImage>,
}

impl TileCache {
    pub(super) fn new(tile_size: u32) -> Self {
        Self {
            tile_size,
            tiles: HashMap::new(),
        }
    }

    pub(super) fn get(&mut self, key: TileKey) -> &RgbImage {
        let tile_size = self.tile_size;
        self.tiles.entry(key).or_insert_with(|| key.draw(tile_size))
    }
}

/// One world tile of `tile_size`² pixels, as `MiniGrid`'s `Grid.render_tile` draws it: black
/// floor with a grey grid line on the top and left edge, the object in `cell` if any, the
/// agent's red triangle pointing along `agent_dir` (0 = right, 1 = down, 2 = left, 3 = up)
/// if given, and everything blended 30 % towards white if `highlight`.
pub fn render_tile(
    cell: Option<WorldObj>,
    agent_dir: Option<u8>,
    highlight: bool,
    tile_size: u32,
) -> RgbImage {
    TileKey::cell(cell, agent_dir, highlight).draw(tile_size)
}

/// The agent's tile in its own view: the carried object, if any, drawn at 45 % size in the
/// top-right corner (where an up-pointing triangle leaves room), under the triangle facing
/// `agent_dir`.
pub fn render_agent_tile(
    carrying: Option<WorldObj>,
    agent_dir: u8,
    highlight: bool,
    tile_size: u32,
) -> RgbImage {
    TileKey::agent(carrying, agent_dir, highlight).draw(tile_size)
}

#[cfg(test)]
mod tests;
