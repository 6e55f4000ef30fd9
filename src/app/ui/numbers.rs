//! The policy's numbers for the step and the word-attention panels: every word's map, the
//! combined map, the word weights and the grounding accuracies.

use eframe::egui;
use egui::{Color32, Sense, Vec2};

use super::{Debugger, Overlay};
use crate::app::session::Shown;
use crate::episode::StepRecord;
use crate::record::StepScene;
use crate::record::scene::action_names;

impl Debugger {
    pub(super) fn attention_panel(
        &mut self,
        ui: &mut egui::Ui,
        step: &StepRecord,
        scene: &StepScene,
    ) {
        let Some(att) = &step.attention else {
            ui.label(
                "no attention maps: the occlusion saliency below (how much the action distribution changes when a cell becomes floor) stands in for them",
            );
            return;
        };
        // One row for every word map plus M: the gaps between the panels come off the width
        // first, or the last panel (M) is cut at the window's edge.
        let panels = (att.words.len() + 1) as f32;
        let gaps = ui.spacing().item_spacing.x * (panels - 1.0);
        let side = ((ui.available_width() - gaps - 4.0) / panels).clamp(70.0, 170.0);
        ui.horizontal_wrapped(|ui| {
            for (i, w) in att.words.iter().enumerate() {
                ui.vertical(|ui| {
                    ui.label(egui::RichText::new(&w.word).strong());
                    ui.label(format!("w {:.3} · H {:.2}", w.weight, w.entropy));
                    let hits = scene
                        .hits_of(Some(i))
                        .map(|g| g.hits.as_slice())
                        .unwrap_or_default();
                    let r = Self::heat_map(
                        ui,
                        &w.map,
                        scene.scale_max,
                        hits,
                        side,
                        i == self.selected_word && self.overlay == Overlay::Word,
                    );
                    if r.clicked() {
                        self.selected_word = i;
                        self.overlay = Overlay::Word;
                    }
                });
            }
            ui.vertical(|ui| {
                ui.label(egui::RichText::new("combined M").strong());
                ui.label(format!("scale 0–{:.3}", scene.scale_max));
                let hits = scene
                    .hits_of(None)
                    .map(|g| g.hits.as_slice())
                    .unwrap_or_default();
                let r = Self::heat_map(
                    ui,
                    &att.combined,
                    scene.scale_max,
                    hits,
                    side,
                    self.overlay == Overlay::Combined,
                );
                if r.clicked() {
                    self.overlay = Overlay::Combined;
                }
            });
        });
        ui.add_space(6.0);
        ui.label("word weights w");
        let labels: Vec<String> = att.words.iter().map(|w| w.word.clone()).collect();
        let values: Vec<f32> = att.words.iter().map(|w| w.weight).collect();
        bars(ui, &labels, &values, Some(self.selected_word));
        for g in &scene.grounding {
            let a = &g.accuracies;
            ui.label(format!(
                "{}: {} related object(s) · acc {:.2} · ng {:.2} · bs {:.2} · cmb {:.2}",
                g.kind.name(),
                g.hits.len(),
                a.acc,
                a.acc_ng,
                a.acc_bs,
                a.acc_cmb
            ));
        }
    }

    pub(super) fn policy_panel(ui: &mut egui::Ui, step: &StepRecord, shown: &Shown) {
        ui.label(egui::RichText::new(&step.world.mission).heading());
        ui.label(format!(
            "step {} of {} · {} · total reward {:.3}",
            step.t,
            shown.len(),
            if shown.trace.success() {
                "success"
            } else {
                "failure"
            },
            shown.trace.total_reward()
        ));
        ui.label(format!(
            "action {} · value {:.3} · reward {:.3}",
            step.action.name(),
            step.value,
            step.reward
        ));
        let labels: Vec<String> = action_names().iter().map(|s| (*s).to_owned()).collect();
        bars(ui, &labels, &step.probs, Some(step.action as usize));
    }
}

/// Horizontal bars with labels and values; `highlight` is drawn in another colour.
fn bars(ui: &mut egui::Ui, labels: &[String], values: &[f32], highlight: Option<usize>) {
    let width = ui.available_width().min(360.0);
    for (i, (l, &v)) in labels.iter().zip(values).enumerate() {
        ui.horizontal(|ui| {
            ui.add_sized([70.0, 16.0], egui::Label::new(l.as_str()).truncate());
            let (rect, _) = ui.allocate_exact_size(Vec2::new(width - 130.0, 14.0), Sense::hover());
            let p = ui.painter_at(rect);
            p.rect_filled(rect, 2.0, ui.visuals().extreme_bg_color);
            let mut bar = rect;
            bar.set_width(rect.width() * v.clamp(0.0, 1.0));
            let color = if highlight == Some(i) {
                Color32::from_rgb(255, 150, 40)
            } else {
                Color32::from_rgb(70, 130, 200)
            };
            p.rect_filled(bar, 2.0, color);
            ui.label(format!("{v:.3}"));
        });
    }
}
