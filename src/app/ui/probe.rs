//! Probing the agent: edit the world at the current step and re-run the policy from there.

use eframe::egui;

use super::Debugger;
use crate::app::session::start_probe;
use crate::env::edit::Edit;
use crate::env::object::{Color, ObjectKind};

impl Debugger {
    pub(super) fn probe(&mut self, edit: &Edit) {
        let (Some(agent), Some(shown)) = (&self.agent, &self.shown) else {
            return;
        };
        match start_probe(agent, shown, self.cursor.step, edit, self.alpha) {
            Ok(job) => self.jobs.push(job),
            Err(e) => self.error(format!("edit refused: {e}")),
        }
    }

    pub(super) fn edit_panel(&mut self, ui: &mut egui::Ui) {
        ui.label(egui::RichText::new("probe").strong());
        let Some(sel) = self.selected_cell else {
            ui.label("click a world cell to edit it");
            if ui.button("turn agent left").clicked() {
                self.turn(3);
            }
            if ui.button("turn agent right").clicked() {
                self.turn(1);
            }
            return;
        };
        ui.label(format!("cell {sel:?}"));
        ui.horizontal_wrapped(|ui| {
            if ui.button("move agent here").clicked() {
                self.probe(&Edit::MoveAgent(sel));
            }
            if ui.button("turn left").clicked() {
                self.turn(3);
            }
            if ui.button("turn right").clicked() {
                self.turn(1);
            }
            if ui.button("remove object").clicked() {
                self.probe(&Edit::Remove(sel));
            }
            if ui
                .button("move object…")
                .on_hover_text("then click the cell to move it to")
                .clicked()
            {
                self.moving_from = Some(sel);
            }
        });
        if let Some(from) = self.moving_from {
            ui.label(format!("click the cell to move the object at {from:?} to"));
        }
        ui.horizontal_wrapped(|ui| {
            egui::ComboBox::from_id_salt("kind")
                .selected_text(self.edit_kind.name())
                .show_ui(ui, |ui| {
                    for k in [ObjectKind::Key, ObjectKind::Ball, ObjectKind::Box] {
                        ui.selectable_value(&mut self.edit_kind, k, k.name());
                    }
                });
            egui::ComboBox::from_id_salt("color")
                .selected_text(self.edit_color.name())
                .show_ui(ui, |ui| {
                    for c in Color::ALL {
                        ui.selectable_value(&mut self.edit_color, c, c.name());
                    }
                });
            if ui.button("add").clicked() {
                self.probe(&Edit::Add(sel, self.edit_kind, self.edit_color));
            }
            if ui.button("recolour").clicked() {
                self.probe(&Edit::Recolor(sel, self.edit_color));
            }
            if ui.button("clear selection").clicked() {
                self.selected_cell = None;
            }
        });
    }

    fn turn(&mut self, by: u8) {
        if let Some(s) = self
            .shown
            .as_ref()
            .and_then(|s| s.trace.steps.get(self.cursor.step))
        {
            let d = (s.world.agent_dir + by) % 4;
            self.probe(&Edit::TurnAgent(d));
        }
    }
}
