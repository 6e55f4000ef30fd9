//! The world panel, on the left: the overlay choice, the world picture with its targets, trail
//! and clause marks ([`crate::app::pictures`]), and the agent's view under it, sized to fit.

use eframe::egui;
use egui::Vec2;

use crate::app::pictures::{Textures, world_picture_ui};
use crate::app::session::{Overlay, Session};

/// The world panel, with the textures of the main episode's pictures.
#[derive(Default)]
pub(super) struct WorldPanel {
    /// Side of the world picture, in points (set by the layout each frame).
    pub(super) side: f32,
    /// Height of the column the panel is in, in points (set by the layout each frame): the
    /// agent's view shrinks to fit under the world.
    pub(super) height: f32,
    textures: Textures,
}

impl WorldPanel {
    /// The overlay choice, the world and the agent's view; the view shrinks (to 96 points at
    /// least) to fit under the world in the column's height.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        let top = ui.cursor().min.y;
        // A model without maps (or the bot) has no M and no word to overlay.
        // (Judged from the episode shown; while none is, everything stays offered.)
        let has_maps = session.shown.as_ref().is_none_or(|s| {
            s.trace
                .steps
                .first()
                .is_none_or(|st| st.attention.is_some())
        });
        let overlay = &mut session.selection.overlay;
        if !has_maps {
            *overlay = Overlay::None;
        }
        ui.horizontal(|ui| {
            ui.label("overlay");
            ui.radio_value(overlay, Overlay::None, "none");
            for (o, name) in [(Overlay::Combined, "M"), (Overlay::Word, "selected word")] {
                let r = ui.add_enabled(has_maps, egui::RadioButton::new(*overlay == o, name));
                if r.clicked() {
                    *overlay = o;
                }
                r.on_disabled_hover_text("this model has no attention maps");
            }
        });
        world_picture_ui(ui, session, &mut self.textures, false, self.side);
        ui.label(
            egui::RichText::new(
                "magenta corners: targets waited on · numbers: clauses · dots: cells visited · floor tint and rings: the map · circles: what the selected word names (colours as on its map)",
            )
            .weak(),
        );
        ui.add_space(6.0);
        ui.label("agent view (agent-up; hatched: not seen)");
        let left = self.height - (ui.cursor().min.y - top) - 10.0;
        let view_side = left.min(self.side * 0.6).clamp(96.0, 200.0);
        let view = session.shown.as_ref().and_then(|s| {
            self.textures.get(
                ui.ctx(),
                s,
                session.generation,
                session.cursor.step,
                (1, false),
            )
        });
        if let Some(t) = view {
            ui.add(egui::Image::new(&t).fit_to_exact_size(Vec2::splat(view_side)));
        }
    }
}
