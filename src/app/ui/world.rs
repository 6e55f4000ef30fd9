//! The world picture with its overlay, and the 7×7 heat maps (also used by the faithfulness
//! view).

use std::fmt::Write as _;

use eframe::egui;
use egui::{
    Color32, ColorImage, Pos2, Rect, Sense, Stroke, StrokeKind, TextureHandle, TextureOptions, Vec2,
};

use super::{Debugger, Overlay};
use crate::env::edit::Edit;
use crate::env::view::{VIEW_SIZE, view_from_world};
use crate::env::{Pos, world_from_view};
use crate::metrics::grounding::{AROUND_NAMES, ObjectHit};
use crate::policy::ViewMap;
use crate::render::colorize;

fn rgb_texture(ctx: &egui::Context, name: &str, img: &image::RgbImage) -> TextureHandle {
    let (w, h) = img.dimensions();
    ctx.load_texture(
        name,
        ColorImage::from_rgb([w as usize, h as usize], img.as_raw()),
        TextureOptions::NEAREST,
    )
}

fn c32(rgb: [u8; 3]) -> Color32 {
    Color32::from_rgb(rgb[0], rgb[1], rgb[2])
}

fn hit_color(h: &ObjectHit) -> Color32 {
    c32(crate::record::scene::hit_color(h))
}

impl Debugger {
    pub(super) fn texture(
        &mut self,
        ctx: &egui::Context,
        step: usize,
        kind: u8,
        compared: bool,
    ) -> Option<TextureHandle> {
        let shown = if compared {
            self.compared.as_ref()?
        } else {
            self.shown.as_ref()?
        };
        let key = (self.generation * 2 + u64::from(compared), step, kind);
        if let Some(t) = self.textures.get(&key) {
            return Some(t.clone());
        }
        let scene = shown.scenes.get(step)?;
        let img = if kind == 0 { &scene.world } else { &scene.view };
        let t = rgb_texture(ctx, &format!("{key:?}"), img);
        self.textures.insert(key, t.clone());
        Some(t)
    }

    /// The world picture with the chosen overlay and grounding marks; click selects a cell.
    pub(super) fn world_panel(&mut self, ui: &mut egui::Ui, compared: bool, side: f32) {
        let step_i = self.cursor.step;
        let Some(shown) = (if compared {
            self.compared.clone()
        } else {
            self.shown.clone()
        }) else {
            ui.label("no episode");
            return;
        };
        let step_i = step_i.min(shown.len().saturating_sub(1));
        let (Some(step), Some(scene)) = (shown.trace.steps.get(step_i), shown.scenes.get(step_i))
        else {
            return;
        };
        let Some(tex) = self.texture(ui.ctx(), step_i, 0, compared) else {
            return;
        };
        let (gw, gh) = (step.world.grid.width(), step.world.grid.height());
        let cell = side / gw.max(gh) as f32;
        let size = Vec2::new(cell * gw as f32, cell * gh as f32);
        let (rect, resp) = ui.allocate_exact_size(size, Sense::click());
        let painter = ui.painter_at(rect);
        painter.image(
            tex.id(),
            rect,
            Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
            Color32::WHITE,
        );
        let map = step.attention.as_ref().and_then(|a| match self.overlay {
            Overlay::None => None,
            Overlay::Combined => Some(a.combined),
            Overlay::Word => a.words.get(self.selected_word).map(|w| w.map),
        });
        let cell_rect = |p: Pos| {
            Rect::from_min_size(
                rect.min + Vec2::new(p.0 as f32 * cell, p.1 as f32 * cell),
                Vec2::splat(cell),
            )
        };
        if let Some(map) = map {
            for (vy, row) in map.iter().enumerate() {
                for (vx, &value) in row.iter().enumerate() {
                    let p = world_from_view(step.world.agent_pos, step.world.agent_dir, (vx, vy));
                    if step.world.grid.contains(p) {
                        let c = colorize(value, 0.0, scene.scale_max);
                        painter.rect_filled(
                            cell_rect(p),
                            0.0,
                            Color32::from_rgba_unmultiplied(c[0], c[1], c[2], 150),
                        );
                    }
                }
            }
        }
        if let Some(sel) = self.selected_cell
            && !compared
        {
            painter.rect_stroke(
                cell_rect(sel),
                0.0,
                Stroke::new(2.0, Color32::from_rgb(0, 160, 255)),
                StrokeKind::Inside,
            );
        }
        if let Some(pos) = resp.hover_pos() {
            let p = (
                ((pos.x - rect.min.x) / cell) as i32,
                ((pos.y - rect.min.y) / cell) as i32,
            );
            let content = match step.world.grid.get(p) {
                Some(o) => o.describe(),
                None if p == step.world.agent_pos => "agent".into(),
                None => "empty".into(),
            };
            let value = view_from_world(step.world.agent_pos, step.world.agent_dir, p)
                .and_then(|v| map.map(|m| (v, m[v.1][v.0])));
            let text = match value {
                Some((v, x)) => format!("cell {p:?}: {content}\nview cell {v:?}, map value {x:.4}"),
                None => format!("cell {p:?}: {content}\n(outside the view)"),
            };
            let resp = resp.clone().on_hover_text_at_pointer(text);
            if resp.clicked() && !compared {
                if let Some(from) = self.moving_from.take() {
                    self.probe(&Edit::MoveObject(from, p));
                }
                self.selected_cell = Some(p);
            }
        }
    }

    /// A 7×7 heat map with grounding marks; returns the response (click selects).
    pub(in crate::app) fn heat_map(
        ui: &mut egui::Ui,
        map: &ViewMap,
        hi: f32,
        hits: &[ObjectHit],
        side: f32,
        selected: bool,
    ) -> egui::Response {
        let (rect, resp) = ui.allocate_exact_size(Vec2::splat(side), Sense::click());
        let painter = ui.painter_at(rect);
        let c = side / VIEW_SIZE as f32;
        for (vy, row) in map.iter().enumerate() {
            for (vx, &v) in row.iter().enumerate() {
                let r = Rect::from_min_size(
                    rect.min + Vec2::new(vx as f32 * c, vy as f32 * c),
                    Vec2::splat(c),
                );
                painter.rect_filled(r, 0.0, c32(colorize(v, 0.0, hi)));
            }
        }
        for h in hits {
            let centre =
                rect.min + Vec2::new((h.cell.0 as f32 + 0.5) * c, (h.cell.1 as f32 + 0.5) * c);
            painter.circle_stroke(centre, c * 0.35, Stroke::new(2.5, hit_color(h)));
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
        if selected {
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
                for h in hits.iter().filter(|h| h.cell == (vx, vy)) {
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
}
