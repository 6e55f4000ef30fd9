//! The 7×7 heat maps (word maps, `M`, occlusion Δ) with their landmarks, and the colour bar
//! that says which scale they share.

use std::fmt::Write as _;

use eframe::egui;
use egui::{Color32, Pos2, Rect, Sense, Stroke, StrokeKind, Vec2};

use crate::env::Observation;
use crate::env::object::ObjectKind;
use crate::env::view::VIEW_SIZE;
use crate::metrics::grounding::{AROUND_NAMES, ObjectHit};
use crate::policy::ViewMap;
use crate::render::{colorize, decode_view_cell, palette};

pub(in crate::app) fn c32(rgb: [u8; 3]) -> Color32 {
    Color32::from_rgb(rgb[0], rgb[1], rgb[2])
}

fn hit_color(h: &ObjectHit) -> Color32 {
    c32(crate::record::scene::hit_color(h))
}

/// How one heat map is drawn.
pub(in crate::app) struct MapLook<'a> {
    /// The top of the colour scale (the bottom is 0).
    pub hi: f32,
    /// Side of the square in points.
    pub side: f32,
    /// Framed as the map laid over the world.
    pub selected: bool,
    /// Greyed out: a word whose weight is (nearly) 0.
    pub dimmed: bool,
    /// The step's observation: walls and objects outlined, unseen cells hatched.
    pub obs: Option<&'a Observation>,
    /// Grounding marks at the related objects.
    pub hits: &'a [ObjectHit],
}

/// Faint landmarks from the observation: walls and objects outlined (objects in their
/// colour), cells the agent does not see hatched, so that a map lighting a row behind a wall
/// reads as such.
fn landmarks(painter: &egui::Painter, rect: Rect, c: f32, obs: &Observation) {
    for vy in 0..VIEW_SIZE {
        for vx in 0..VIEW_SIZE {
            let r = Rect::from_min_size(
                rect.min + Vec2::new(vx as f32 * c, vy as f32 * c),
                Vec2::splat(c),
            );
            match decode_view_cell(obs.at((vx, vy))) {
                None => {
                    let stroke = Stroke::new(1.0, Color32::from_white_alpha(70));
                    for k in 1..4 {
                        let t = k as f32 / 4.0 * c;
                        painter.line_segment(
                            [
                                Pos2::new(r.min.x, r.min.y + t),
                                Pos2::new(r.min.x + t, r.min.y),
                            ],
                            stroke,
                        );
                        painter.line_segment(
                            [
                                Pos2::new(r.max.x - t, r.max.y),
                                Pos2::new(r.max.x, r.max.y - t),
                            ],
                            stroke,
                        );
                    }
                }
                Some(Some(o)) if o.kind == ObjectKind::Wall => {
                    painter.rect_stroke(
                        r.shrink(1.0),
                        0.0,
                        Stroke::new(1.0, Color32::from_white_alpha(90)),
                        StrokeKind::Inside,
                    );
                }
                Some(Some(o)) => {
                    let [red, g, b] = palette::object(o.color);
                    painter.rect_stroke(
                        r.shrink(c * 0.22),
                        c * 0.1,
                        Stroke::new(1.5, Color32::from_rgba_unmultiplied(red, g, b, 190)),
                        StrokeKind::Inside,
                    );
                }
                Some(None) => {}
            }
        }
    }
}

/// A 7×7 heat map with landmarks and grounding marks; returns the response (click
/// selects).
pub(in crate::app) fn heat_map(
    ui: &mut egui::Ui,
    map: &ViewMap,
    look: &MapLook<'_>,
) -> egui::Response {
    let (rect, resp) = ui.allocate_exact_size(Vec2::splat(look.side), Sense::click());
    let painter = ui.painter_at(rect);
    let c = look.side / VIEW_SIZE as f32;
    for (vy, row) in map.iter().enumerate() {
        for (vx, &v) in row.iter().enumerate() {
            let r = Rect::from_min_size(
                rect.min + Vec2::new(vx as f32 * c, vy as f32 * c),
                Vec2::splat(c),
            );
            painter.rect_filled(r, 0.0, c32(colorize(v, 0.0, look.hi)));
        }
    }
    if let Some(obs) = look.obs {
        landmarks(&painter, rect, c, obs);
    }
    for h in look.hits {
        let centre = rect.min + Vec2::new((h.cell.0 as f32 + 0.5) * c, (h.cell.1 as f32 + 0.5) * c);
        painter.circle_stroke(centre, c * 0.42, Stroke::new(2.5, hit_color(h)));
    }
    // The agent, bottom middle, facing up.
    let a = rect.min + Vec2::new(3.5 * c, 6.5 * c);
    painter.add(egui::Shape::convex_polygon(
        vec![
            a + Vec2::new(0.0, -0.3 * c),
            a + Vec2::new(0.25 * c, 0.25 * c),
            a + Vec2::new(-0.25 * c, 0.25 * c),
        ],
        Color32::from_rgb(255, 80, 80),
        Stroke::NONE,
    ));
    if look.dimmed {
        painter.rect_filled(rect, 0.0, Color32::from_rgba_unmultiplied(40, 40, 40, 190));
    }
    if look.selected {
        painter.rect_stroke(
            rect,
            0.0,
            Stroke::new(3.0, Color32::from_rgb(0, 160, 255)),
            StrokeKind::Inside,
        );
    }
    if let Some(pos) = resp.hover_pos() {
        let (vx, vy) = (
            ((pos.x - rect.min.x) / c) as usize,
            ((pos.y - rect.min.y) / c) as usize,
        );
        if vx < VIEW_SIZE && vy < VIEW_SIZE {
            let mut text = format!("view cell ({vx}, {vy}): {:.5}", map[vy][vx]);
            if let Some(obs) = look.obs {
                match decode_view_cell(obs.at((vx, vy))) {
                    None => text.push_str(" · not seen"),
                    Some(Some(o)) => {
                        let _ = write!(text, " · {}", o.describe());
                    }
                    Some(None) => {}
                }
            }
            for h in look.hits.iter().filter(|h| h.cell == (vx, vy)) {
                let _ = write!(
                    text,
                    "\nrelated object: acc {} · ng {} · bs {} · cmb {}",
                    h.acc, h.acc_ng, h.acc_bs, h.acc_cmb
                );
                // Which neighbouring cells pass τ: where a map that misses it sits.
                let sides: Vec<&str> = AROUND_NAMES
                    .iter()
                    .zip(h.around)
                    .filter_map(|(n, hit)| hit.then_some(*n))
                    .collect();
                if !sides.is_empty() {
                    let _ = write!(text, "\n≥ τ: {}", sides.join(", "));
                }
            }
            return resp.on_hover_text_at_pointer(text);
        }
    }
    resp
}

/// A vertical colour bar `height` points tall for the scale `0..=hi`, with its ends
/// labelled and a caption saying which maps use it.
pub(in crate::app) fn color_bar(ui: &mut egui::Ui, hi: f32, height: f32, caption: &str) {
    color_bar_labelled(ui, &format!("{hi:.3}"), hi, height, caption);
}

/// [`color_bar`] with its top labelled `top` (`"max"`: each map's own largest value).
pub(in crate::app) fn color_bar_labelled(
    ui: &mut egui::Ui,
    top: &str,
    hi: f32,
    height: f32,
    caption: &str,
) {
    ui.vertical(|ui| {
        ui.label(top);
        let (rect, _) = ui.allocate_exact_size(Vec2::new(14.0, height), Sense::hover());
        let painter = ui.painter_at(rect);
        let n = 48;
        for i in 0..n {
            let t = 1.0 - i as f32 / (n - 1) as f32;
            let y0 = rect.min.y + rect.height() * i as f32 / n as f32;
            let r = Rect::from_min_max(
                Pos2::new(rect.min.x, y0),
                Pos2::new(rect.max.x, y0 + rect.height() / n as f32 + 0.5),
            );
            painter.rect_filled(r, 0.0, c32(colorize(t * hi, 0.0, hi)));
        }
        ui.label("0");
        ui.label(egui::RichText::new(caption).small().weak());
    });
}
