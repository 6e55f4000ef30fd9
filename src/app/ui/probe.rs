//! The probe panel, under the world: edit the world at the current step (move or turn the
//! agent, remove, add, recolour or move an object) and re-run the policy from there.

use eframe::egui;

use crate::app::session::Session;
use crate::env::edit::Edit;
use crate::env::object::{Color, ObjectKind};

/// The probe panel, with the kind and colour an added or recoloured object gets.
pub(super) struct ProbePanel {
    color: Color,
    kind: ObjectKind,
}

impl Default for ProbePanel {
    fn default() -> Self {
        Self {
            color: Color::Red,
            kind: ObjectKind::Ball,
        }
    }
}

impl ProbePanel {
    /// The edits of the selected cell (or, with none selected, the agent's turns).
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        ui.label(egui::RichText::new("probe").strong());
        let Some(sel) = session.selection.cell else {
            ui.label("click a world cell to edit it");
            if ui.button("turn agent left").clicked() {
                session.turn(3);
            }
            if ui.button("turn agent right").clicked() {
                session.turn(1);
            }
            return;
        };
        ui.label(format!("cell {sel:?}"));
        ui.horizontal_wrapped(|ui| {
            if ui.button("move agent here").clicked() {
                session.probe(&Edit::MoveAgent(sel));
            }
            if ui.button("turn left").clicked() {
                session.turn(3);
            }
            if ui.button("turn right").clicked() {
                session.turn(1);
            }
            if ui.button("remove object").clicked() {
                session.probe(&Edit::Remove(sel));
            }
            if ui
                .button("move object…")
                .on_hover_text("then click the cell to move it to")
                .clicked()
            {
                session.selection.moving_from = Some(sel);
            }
        });
        if let Some(from) = session.selection.moving_from {
            ui.label(format!("click the cell to move the object at {from:?} to"));
        }
        ui.horizontal_wrapped(|ui| {
            egui::ComboBox::from_id_salt("kind")
                .selected_text(self.kind.name())
                .show_ui(ui, |ui| {
                    for k in [ObjectKind::Key, ObjectKind::Ball, ObjectKind::Box] {
                        ui.selectable_value(&mut self.kind, k, k.name());
                    }
                });
            egui::ComboBox::from_id_salt("color")
                .selected_text(self.color.name())
                .show_ui(ui, |ui| {
                    for c in Color::ALL {
                        ui.selectable_value(&mut self.color, c, c.name());
                    }
                });
            if ui.button("add").clicked() {
                session.probe(&Edit::Add(sel, self.kind, self.color));
            }
            if ui.button("recolour").clicked() {
                session.probe(&Edit::Recolor(sel, self.color));
            }
            if ui.button("clear selection").clicked() {
                session.selection.cell = None;
            }
        });
    }
}
