//! The compare panel, on the right in compare mode: the second checkpoint's name, its world
//! on the same seed at the same step, and its policy's numbers there.

use eframe::egui;

use crate::app::numbers::policy_panel;
use crate::app::pictures::{Textures, world_picture_ui};
use crate::app::session::Session;

/// The compare panel, with the textures of the compared episode's pictures.
#[derive(Default)]
pub(super) struct ComparePanel {
    textures: Textures,
}

impl ComparePanel {
    /// The compared checkpoint's name, world and policy at the cursor.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        let Some(c) = session.compared.clone() else {
            return;
        };
        ui.label(
            egui::RichText::new(format!(
                "compare: {}",
                c.trace.model_name.as_ref().unwrap_or(&c.trace.checkpoint)
            ))
            .strong(),
        );
        let side = ui.available_width().min(300.0);
        world_picture_ui(ui, session, &mut self.textures, true, side);
        let i = session.cursor.step.min(c.len().saturating_sub(1));
        if let Some(step) = c.trace.steps.get(i) {
            policy_panel(ui, step, &c);
        }
    }
}
