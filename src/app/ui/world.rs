//! The world picture with its overlay, targets and trail, and what the cursor says about it.

use eframe::egui;
use egui::{
    Color32, ColorImage, Pos2, Rect, Sense, Stroke, StrokeKind, TextureHandle, TextureOptions, Vec2,
};

use super::{Debugger, Overlay};
use crate::env::Pos;
use crate::env::edit::Edit;
use crate::env::view::view_from_world;
use crate::record::scene::{trail, world_picture};

/// The margin around the world picture, in [`BACKING`]: the outer walls, `MiniGrid`'s grey,
/// stand out from it where the map does not tint them; on egui's dark panel they would not.
const MARGIN: f32 = 3.0;

/// The colour of [`MARGIN`]: black, the floor's colour, so the margin reads as the world's
/// own edge.
const BACKING: Color32 = Color32::BLACK;

/// How many step pictures stay on the GPU: the steps around the cursor, in both episodes of
/// compare mode, with every overlay of the last few.
const TEXTURES_KEPT: usize = 64;

fn rgb_texture(ctx: &egui::Context, name: &str, img: &image::RgbImage) -> TextureHandle {
    let (w, h) = img.dimensions();
    ctx.load_texture(
        name,
        ColorImage::from_rgb([w as usize, h as usize], img.as_raw()),
        TextureOptions::NEAREST,
    )
}

impl Debugger {
    /// The texture of step `step`'s picture `kind` (see [`Self::picture`]), cached per
    /// episode generation.
    pub(super) fn texture(
        &mut self,
        ctx: &egui::Context,
        step: usize,
        kind: u8,
        compared: bool,
    ) -> Option<TextureHandle> {
        let key = (self.generation * 2 + u64::from(compared), step, kind);
        if let Some(t) = self.textures.get(&key) {
            return Some(t.clone());
        }
        let img = self.picture(step, kind, compared)?;
        let t = rgb_texture(ctx, &format!("{key:?}"), &img);
        if self.textures.len() >= TEXTURES_KEPT {
            // Playing a long episode would otherwise keep every step's pictures (0.5 MB each
            // on a 22×22 world): the half farthest from this step goes.
            let mut keys: Vec<_> = self.textures.keys().copied().collect();
            keys.sort_by_key(|k| (k.0 != key.0, k.1.abs_diff(step)));
            for k in keys.split_off(TEXTURES_KEPT / 2) {
                self.textures.remove(&k);
            }
        }
        self.textures.insert(key, t.clone());
        Some(t)
    }

    /// Picture `kind` of step `step`: 1 the agent's view; 0 the world with its targets and
    /// trail; 2 that with `M` over it; `3 + i` with word `i`'s map over it.
    fn picture(&self, step: usize, kind: u8, compared: bool) -> Option<image::RgbImage> {
        let shown = if compared {
            self.compared.as_ref()?
        } else {
            self.shown.as_ref()?
        };
        let scene = shown.scene(step)?;
        if kind == 1 {
            return Some(scene.view.clone());
        }
        let record = shown.trace.steps.get(step)?;
        let map = record.attention.as_ref().and_then(|a| match kind {
            2 => Some(&a.combined),
            3.. => a.words.get(usize::from(kind - 3)).map(|w| &w.map),
            _ => None,
        });
        Some(world_picture(
            record,
            &scene.world,
            map,
            scene.scale_max,
            &trail(&shown.trace, step),
        ))
    }

    /// The picture kind the overlay choice asks for (see [`Self::picture`]).
    fn world_kind(&self) -> u8 {
        match self.overlay {
            Overlay::None => 0,
            Overlay::Combined => 2,
            Overlay::Word => 3u8.saturating_add(u8::try_from(self.selected_word).unwrap_or(250)),
        }
    }

    /// The picture the world panel shows now (the main episode at the cursor, with the chosen
    /// overlay): objects in their true colours, the floor tinted by the map, targets
    /// outlined, the trail dotted. `None` before the first episode.
    pub fn world_image(&self) -> Option<image::RgbImage> {
        let len = self.shown.as_ref()?.len();
        self.picture(
            self.cursor.step.min(len.saturating_sub(1)),
            self.world_kind(),
            false,
        )
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
        let Some(step) = shown.trace.steps.get(step_i) else {
            return;
        };
        let kind = self.world_kind();
        let Some(tex) = self.texture(ui.ctx(), step_i, kind, compared) else {
            return;
        };
        let (gw, gh) = (step.world.grid.width(), step.world.grid.height());
        let cell = side / gw.max(gh) as f32;
        let size = Vec2::new(cell * gw as f32, cell * gh as f32);
        let (outer, resp) =
            ui.allocate_exact_size(size + Vec2::splat(2.0 * MARGIN), Sense::click());
        ui.painter().rect_filled(outer, 0.0, BACKING);
        let rect = outer.shrink(MARGIN);
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
        if let Some(scene) = shown.scene(step_i) {
            Self::paint_clause_marks(&painter, &scene.clauses, cell_rect);
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
        if let Some(pos) = resp.hover_pos().filter(|p| rect.contains(*p)) {
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
}

#[cfg(test)]
mod tests {
    use super::{BACKING, Color32};
    use crate::env::Color;
    use crate::render::palette;

    /// Walls stay distinct from what surrounds the picture: an unlit wall (`MiniGrid`'s grey)
    /// reaches WCAG's 3:1 for graphics against the margin, which it does not against egui's
    /// dark panel.
    #[test]
    fn walls_stand_out_from_the_pictures_margin() {
        let wall = palette::object(Color::Grey);
        let rgb = |c: Color32| [c.r(), c.g(), c.b()];
        let (backing, panel) = (rgb(BACKING), rgb(eframe::egui::Visuals::dark().panel_fill));
        let (ours, theirs) = (
            palette::contrast(wall, backing),
            palette::contrast(wall, panel),
        );
        assert!(ours >= 3.0, "{ours}");
        assert!(theirs < 3.0, "{theirs}");
    }
}
