//! What makes the Rerun views read at a glance: bar charts whose every bar carries its name
//! and value (Rerun 0.36's `BarChart` has no per-bar names, so bars are tracks with solid bars
//! inside and a label above each, in a 2-D view), landmarks shared by every map (walls, objects, unseen
//! cells, the agent), the world's attention rings, targets, numbered clause targets and trail,
//! and the colour bar of the maps' shared scale.

use rerun::RecordingStream;

use super::{RecordError, sdk};
use crate::env::object::ObjectKind;
use crate::env::{Observation, Pos, VIEW_SIZE};
use crate::record::scene::{ClauseMark, stage_color};
use crate::render::{decode_view_cell, palette};

/// Length of a full bar (probability or weight 1) in the bars' 2-D space.
pub const BAR_LENGTH: f32 = 10.0;

/// Rows of a bar chart are this far apart: each row is its label's band, then its bar
/// ([`BAR_HEIGHT`]), then a gap ([`BAR_GAP`]) before the next row's label.
pub const BAR_PITCH: f32 = 3.0;

/// Height of one bar.
pub const BAR_HEIGHT: f32 = 0.8;

/// Gap between a bar and the next row's label band.
pub const BAR_GAP: f32 = 0.2;

/// Rows a bar chart's view shows at first; a longer chart (a long mission's words) scrolls,
/// since Rerun draws labels at a fixed size in pixels and more rows would overprint them.
pub const BAR_ROWS_SHOWN: usize = 8;

/// Top of row `i`'s bar (y grows downward).
pub fn bar_top(i: usize) -> f32 {
    (i + 1) as f32 * BAR_PITCH - BAR_GAP - BAR_HEIGHT
}

/// Where row `i`'s label is anchored: mid-width at the top of its row. Rerun 0.36 draws a
/// 2-D label centred *below* its anchor (a box's label below the box), so the text lies in
/// the row's label band, right above its own bar; a label anchored on the bar itself would
/// sit over the next row's bar, and the last one under the chart's edge.
pub fn label_anchor(i: usize) -> (f32, f32) {
    (BAR_LENGTH / 2.0, i as f32 * BAR_PITCH)
}

/// A bar chart as logged: the labels (invisible points, one per row, at [`label_anchor`]),
/// the rows' full-length grey tracks and the solid bars.
pub struct LabelledBars {
    /// One label per row, e.g. `"forward 0.910"`.
    pub labels: rerun::Points2D,
    /// The rows' full-length tracks.
    pub tracks: rerun::Boxes2D,
    /// The bars (`highlight` in [`palette::CHOSEN_BAR`], the others [`palette::BAR`]).
    pub bars: rerun::LineStrips2D,
}

/// Where the landmarks every map view also shows are logged.
pub const LANDMARKS: &str = "attention/landmarks";

/// Entity holding the marks drawn over the world in cell units (scaled by the tile size).
pub const WORLD_MARKS: &str = "world/marks";

/// Horizontal bars, one per `(label, value)` row, value `full` = [`BAR_LENGTH`], each row's
/// label right above its bar ([`label_anchor`]). Rerun 0.36's boxes have no fill, so a bar is a
/// line strip along the row's bar, as thick as the bar: a solid bar of the right length.
pub fn labelled_bars(rows: &[(String, f32)], full: f32, highlight: Option<usize>) -> LabelledBars {
    let scale = BAR_LENGTH / full.max(f32::EPSILON);
    let labels = rerun::Points2D::new((0..rows.len()).map(label_anchor))
        .with_radii([0.0])
        .with_labels(rows.iter().map(|(l, _)| l.clone()))
        .with_show_labels(true)
        .with_colors([[220, 220, 220]]);
    let tracks = rerun::Boxes2D::from_mins_and_sizes(
        (0..rows.len()).map(|i| (0.0, bar_top(i))),
        vec![(BAR_LENGTH, BAR_HEIGHT); rows.len()],
    )
    .with_colors([[70, 70, 70]]);
    let strips: Vec<[[f32; 2]; 2]> = rows
        .iter()
        .enumerate()
        .map(|(i, (_, v))| {
            // The viewer rounds a strip's ends by its radius: the strip stops a radius short
            // of each end so the bar covers exactly [0, length] (a dot at least).
            let (y, r) = (bar_top(i) + BAR_HEIGHT / 2.0, BAR_HEIGHT / 2.0);
            let length = (v.max(0.0) * scale).min(BAR_LENGTH);
            [[r, y], [(length - r).max(r), y]]
        })
        .collect();
    let colors: Vec<[u8; 3]> = (0..rows.len())
        .map(|i| {
            if highlight == Some(i) {
                palette::CHOSEN_BAR
            } else {
                palette::BAR
            }
        })
        .collect();
    let bars = rerun::LineStrips2D::new(strips)
        .with_colors(colors)
        .with_radii([BAR_HEIGHT / 2.0]);
    LabelledBars {
        labels,
        tracks,
        bars,
    }
}

/// The frame of a bar chart with `n` rows: fixes the view's bounds so bars do not rescale.
pub fn bar_frame(n: usize) -> rerun::Boxes2D {
    rerun::Boxes2D::from_mins_and_sizes([(0.0, 0.0)], [(BAR_LENGTH, n as f32 * BAR_PITCH)])
        .with_colors([[80, 80, 80]])
}

/// Logs the landmarks of the step's view for every map (their views include
/// [`LANDMARKS`]): walls outlined grey, objects in their colour, unseen cells hatched.
pub fn log_landmarks(rec: &RecordingStream, obs: &Observation) -> Result<(), RecordError> {
    let (mut walls, mut objects, mut colors, mut hatch) = (vec![], vec![], vec![], vec![]);
    for vy in 0..VIEW_SIZE {
        for vx in 0..VIEW_SIZE {
            let (x, y) = (vx as f32, vy as f32);
            match decode_view_cell(obs.at((vx, vy))) {
                None => {
                    for k in 1..3 {
                        let t = k as f32 / 3.0;
                        hatch.push(vec![[x, y + t], [x + t, y]]);
                        hatch.push(vec![[x + 1.0 - t, y + 1.0], [x + 1.0, y + 1.0 - t]]);
                    }
                }
                Some(Some(o)) if o.kind == ObjectKind::Wall => walls.push((x + 0.05, y + 0.05)),
                Some(Some(o)) => {
                    objects.push((x + 0.22, y + 0.22));
                    colors.push(palette::object(o.color));
                }
                Some(None) => {}
            }
        }
    }
    let boxes = |mins: Vec<(f32, f32)>, side: f32| {
        let n = mins.len();
        rerun::Boxes2D::from_mins_and_sizes(mins, vec![(side, side); n])
    };
    rec.log(
        format!("{LANDMARKS}/walls"),
        &boxes(walls, 0.9)
            .with_colors([[150, 150, 150]])
            .with_radii([0.02])
            .with_draw_order(20.0),
    )
    .map_err(sdk)?;
    rec.log(
        format!("{LANDMARKS}/objects"),
        &boxes(objects, 0.56)
            .with_colors(colors)
            .with_radii([0.04])
            .with_draw_order(20.0),
    )
    .map_err(sdk)?;
    rec.log(
        format!("{LANDMARKS}/unseen"),
        &rerun::LineStrips2D::new(hatch)
            .with_colors([[110, 110, 110]])
            .with_radii([0.01])
            .with_draw_order(20.0),
    )
    .map_err(sdk)
}

/// The agent's marker on every map, bottom middle: static, since it never moves there.
pub fn agent_marker() -> rerun::Points2D {
    rerun::Points2D::new([(3.5, 6.5)])
        .with_colors([palette::AGENT])
        .with_radii([0.25])
        .with_labels(["agent"])
        .with_show_labels(false)
}

/// Outlines of occupied cells in the map's colour (the overlay rings), in cell units.
pub fn rings(cells: &[(Pos, [u8; 3])]) -> rerun::Boxes2D {
    rerun::Boxes2D::from_mins_and_sizes(
        cells
            .iter()
            .map(|((x, y), _)| (*x as f32 + 0.06, *y as f32 + 0.06)),
        vec![(0.88, 0.88); cells.len()],
    )
    .with_colors(cells.iter().map(|(_, c)| *c))
    .with_radii([0.06])
    .with_draw_order(20.0)
}

/// The targets outlined in magenta, in cell units.
pub fn targets(cells: &[Pos]) -> rerun::Boxes2D {
    rerun::Boxes2D::from_mins_and_sizes(
        cells
            .iter()
            .map(|(x, y)| (*x as f32 + 0.15, *y as f32 + 0.15)),
        vec![(0.7, 0.7); cells.len()],
    )
    .with_colors([palette::TARGET])
    .with_radii([0.05])
    .with_labels(vec!["target"; cells.len()])
    .with_show_labels(false)
    .with_draw_order(25.0)
}

/// The clause marks ([`ClauseMark`]), framed in their stage's colour (waited on: magenta;
/// done: grey; later: blue), and their clause numbers (PutNext's second description primed:
/// `1'`) written in the free cell beside each ([`ClauseMark::label_at`]), in pixels of a world
/// picture of `tile` pixels a cell: the viewer draws a label where its anchor would be without
/// its entity's transform, so labels cannot use the cell units of [`WORLD_MARKS`].
pub fn clause_targets(marks: &[ClauseMark], tile: f32) -> (rerun::Boxes2D, rerun::Points2D) {
    let frames = rerun::Boxes2D::from_mins_and_sizes(
        marks.iter().map(|m| {
            (
                (m.pos.0 as f32 + 0.05) * tile,
                (m.pos.1 as f32 + 0.05) * tile,
            )
        }),
        vec![(0.9 * tile, 0.9 * tile); marks.len()],
    )
    .with_colors(marks.iter().map(|m| stage_color(m.stage)))
    .with_radii([0.03 * tile])
    .with_draw_order(24.0);
    // Rerun 0.36 writes a point's label centred below it: anchored at the top of the label's
    // cell (at its middle where the numbers share their target's cell), the text lies inside.
    let labels = rerun::Points2D::new(marks.iter().map(|m| {
        let top = if m.label_at == m.pos { 0.5 } else { 0.0 };
        (
            (m.label_at.0 as f32 + 0.5) * tile,
            (m.label_at.1 as f32 + top) * tile,
        )
    }))
    .with_radii([0.0])
    .with_labels(marks.iter().map(|m| m.label.clone()))
    .with_colors(marks.iter().map(|m| stage_color(m.stage)))
    .with_show_labels(true)
    .with_draw_order(24.5);
    (frames, labels)
}

/// The agent's path through the centres of the cells it stood on, up to `now`, in cell units.
pub fn trail(path: &[Pos]) -> rerun::LineStrips2D {
    let strip: Vec<[f32; 2]> = path
        .iter()
        .map(|(x, y)| [*x as f32 + 0.5, *y as f32 + 0.5])
        .collect();
    rerun::LineStrips2D::new([strip])
        .with_colors([palette::TRAIL])
        .with_radii([0.06])
        .with_labels(["trail"])
        .with_show_labels(false)
        .with_draw_order(22.0)
}

/// The colour bar of the maps' shared scale: a 1×32 depth image from `hi` (top) to 0.
pub fn colorbar(hi: f32) -> rerun::DepthImage {
    let n = 32;
    let bytes: Vec<u8> = (0..n)
        .map(|i| hi * (1.0 - i as f32 / (n - 1) as f32))
        .flat_map(f32::to_le_bytes)
        .collect();
    rerun::DepthImage::from_data_type_and_bytes(bytes, [1, n], rerun::ChannelDatatype::F32)
        .with_colormap(rerun::components::Colormap::Viridis)
        .with_depth_range([0.0, f64::from(hi)])
}
