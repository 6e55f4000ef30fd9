//! The world and view pictures of a step, their textures on the GPU, and the world picture
//! drawn with its clause marks, the selected cell and what the cursor says about a cell: shared
//! by the world panel and the compare panel.

use std::collections::HashMap;

use eframe::egui;
use egui::{
    Color32, ColorImage, Pos2, Rect, Sense, Stroke, StrokeKind, TextureHandle, TextureOptions, Vec2,
};

use super::session::{Overlay, Session, Shown};
use crate::env::Pos;
use crate::env::edit::Edit;
use crate::env::view::view_from_world;
use crate::record::scene::{map_scale_max, referent_marks, trail, world_picture};

/// The margin around the world picture, in [`BACKING`]: the outer walls, `MiniGrid`'s grey,
/// stand out from it where the map does not tint them; on egui's dark panel they would not.
const MARGIN: f32 = 3.0;

/// The colour of [`MARGIN`]: black, the floor's colour, so the margin reads as the world's
/// own edge.
const BACKING: Color32 = Color32::BLACK;

/// How many step pictures one cache keeps on the GPU: the steps around the cursor, with
/// every overlay of the last few.
const TEXTURES_KEPT: usize = 64;

/// Picture `kind` of step `step` of `shown`: 1 the agent's view; 0 the world with its targets
/// and trail; 2 that with `M` over it; `3 + i` with word `i`'s map over it and the objects the
/// word names circled by whether the map passes τ on them (as the 7×7 maps circle them). The
/// map is coloured on the step's shared scale, or with `own_scale` from 0 to its own largest
/// value, as the maps beside it are.
pub fn picture(shown: &Shown, step: usize, kind: u8, own_scale: bool) -> Option<image::RgbImage> {
    let scene = shown.scene(step)?;
    if kind == 1 {
        return Some(scene.view.clone());
    }
    let record = shown.trace.steps.get(step)?;
    let word = kind.checked_sub(3).map(usize::from);
    let map = record.attention.as_ref().and_then(|a| match (kind, word) {
        (2, _) => Some(&a.combined),
        (_, Some(i)) => a.words.get(i).map(|w| &w.map),
        _ => None,
    });
    let hi = match map {
        Some(m) if own_scale => map_scale_max(m),
        _ => scene.scale_max,
    };
    // `M`'s targets have their magenta corners; a word's related objects get their circles.
    let referents = match (map, word) {
        (Some(_), Some(i)) => referent_marks(&record.world, scene.hits_of(Some(i))),
        _ => Vec::new(),
    };
    Some(world_picture(
        record,
        &scene.world,
        map,
        hi,
        &trail(&shown.trace, step),
        &referents,
    ))
}

fn rgb_texture(ctx: &egui::Context, name: &str, img: &image::RgbImage) -> TextureHandle {
    let (w, h) = img.dimensions();
    ctx.load_texture(
        name,
        ColorImage::from_rgb([w as usize, h as usize], img.as_raw()),
        TextureOptions::NEAREST,
    )
}

/// One episode's step pictures as textures, for the episode generation they were drawn for.
#[derive(Default)]
pub struct Textures {
    generation: u64,
    by_step: HashMap<(usize, u8, bool), TextureHandle>,
}

impl Textures {
    /// The texture of picture `kind` of step `step` of `shown` ([`picture`], its map on its
    /// own scale with `own_scale`), drawn now unless it is cached for this `generation` of
    /// the episode.
    pub fn get(
        &mut self,
        ctx: &egui::Context,
        shown: &Shown,
        generation: u64,
        step: usize,
        (kind, own_scale): (u8, bool),
    ) -> Option<TextureHandle> {
        if self.generation != generation {
            self.by_step.clear();
            self.generation = generation;
        }
        let key = (step, kind, own_scale);
        if let Some(t) = self.by_step.get(&key) {
            return Some(t.clone());
        }
        let img = picture(shown, step, kind, own_scale)?;
        let t = rgb_texture(ctx, &format!("{generation} {key:?}"), &img);
        if self.by_step.len() >= TEXTURES_KEPT {
            // Playing a long episode would otherwise keep every step's pictures (0.5 MB each
            // on a 22×22 world): the half farthest from this step goes.
            let mut keys: Vec<_> = self.by_step.keys().copied().collect();
            keys.sort_by_key(|k| k.0.abs_diff(step));
            for k in keys.split_off(TEXTURES_KEPT / 2) {
                self.by_step.remove(&k);
            }
        }
        self.by_step.insert(key, t.clone());
        Some(t)
    }
}

/// The world picture of the main episode (or, `compared`, the compared one) at the cursor,
/// `side` points across, with the chosen overlay, the clause marks and the selected cell;
/// hovering a cell says what it holds and the map's value there, and a click on the main
/// world selects the cell (or drops the object being moved there).
pub fn world_picture_ui(
    ui: &mut egui::Ui,
    session: &mut Session,
    textures: &mut Textures,
    compared: bool,
    side: f32,
) {
    let Some(shown) = (if compared {
        session.compared.clone()
    } else {
        session.shown.clone()
    }) else {
        ui.label("no episode");
        return;
    };
    let step_i = session.cursor.step.min(shown.len().saturating_sub(1));
    let Some(step) = shown.trace.steps.get(step_i) else {
        return;
    };
    let selection = &session.selection;
    let kind = selection.world_kind();
    let own = selection.own_scale(step.world.rules.is_some());
    let Some(tex) = textures.get(ui.ctx(), &shown, session.generation, step_i, (kind, own)) else {
        return;
    };
    let (gw, gh) = (step.world.grid.width(), step.world.grid.height());
    let cell = side / gw.max(gh) as f32;
    let size = Vec2::new(cell * gw as f32, cell * gh as f32);
    let (outer, resp) = ui.allocate_exact_size(size + Vec2::splat(2.0 * MARGIN), Sense::click());
    // Named, so that a test (or a screen reader) finds where the world was drawn.
    let name = if compared {
        "compared world picture"
    } else {
        "world picture"
    };
    resp.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, name));
    ui.painter().rect_filled(outer, 0.0, BACKING);
    let rect = outer.shrink(MARGIN);
    let painter = ui.painter_at(rect);
    painter.image(
        tex.id(),
        rect,
        Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
        Color32::WHITE,
    );
    let map = step
        .attention
        .as_ref()
        .and_then(|a| match selection.overlay {
            Overlay::None => None,
            Overlay::Combined => Some(a.combined),
            Overlay::Word => a.words.get(selection.word).map(|w| w.map),
        });
    let cell_rect = |p: Pos| {
        Rect::from_min_size(
            rect.min + Vec2::new(p.0 as f32 * cell, p.1 as f32 * cell),
            Vec2::splat(cell),
        )
    };
    if let Some(scene) = shown.scene(step_i) {
        super::tree::paint_clause_marks(&painter, &scene.clauses, cell_rect);
    }
    if let Some(sel) = selection.cell
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
            if let Some(from) = session.selection.moving_from.take() {
                session.probe(&Edit::MoveObject(from, p));
            }
            session.selection.cell = Some(p);
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
