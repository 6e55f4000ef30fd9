//! The episode at a glance, under the step's panels: each word's weight w and the chosen
//! action's probability over every step, with the cursor; a click moves the cursor there.

use eframe::egui;
use egui::{Color32, Pos2, Sense, Stroke, Vec2};

use super::Debugger;
use crate::app::session::Shown;

/// Line colours of the words, in mission order (repeating past the end); chosen off the
/// viridis ramp's dark end so that they read on the dark panel.
const WORD_COLORS: [Color32; 6] = [
    Color32::from_rgb(86, 180, 233),
    Color32::from_rgb(230, 159, 0),
    Color32::from_rgb(0, 158, 115),
    Color32::from_rgb(204, 121, 167),
    Color32::from_rgb(240, 228, 66),
    Color32::from_rgb(213, 94, 0),
];

impl Debugger {
    /// Draws the plot `height` points tall across the available width.
    pub(super) fn history_ui(&mut self, ui: &mut egui::Ui, shown: &Shown, height: f32) {
        let steps = &shown.trace.steps;
        if steps.is_empty() {
            return;
        }
        let words: Vec<String> = steps
            .first()
            .and_then(|s| s.attention.as_ref())
            .map(|a| a.words.iter().map(|w| w.word.clone()).collect())
            .unwrap_or_default();
        ui.horizontal_wrapped(|ui| {
            ui.label("over the episode:");
            for (i, w) in words.iter().enumerate() {
                ui.colored_label(WORD_COLORS[i % WORD_COLORS.len()], format!("w of {w}"));
            }
            ui.colored_label(Color32::GRAY, "p of the chosen action");
            ui.colored_label(super::numbers::EXPERT_LEFT, "| left the expert's plan");
        });
        let width = ui.available_width().max(100.0);
        let (rect, resp) = ui.allocate_exact_size(Vec2::new(width, height), Sense::click());
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 2.0, ui.visuals().extreme_bg_color);
        let last = steps.len().saturating_sub(1).max(1) as f32;
        let at = |k: usize, v: f32| {
            Pos2::new(
                rect.min.x + rect.width() * k as f32 / last,
                rect.max.y - rect.height() * v.clamp(0.0, 1.0),
            )
        };
        let chosen: Vec<Pos2> = steps
            .iter()
            .enumerate()
            .map(|(k, s)| at(k, s.probs.get(s.action as usize).copied().unwrap_or(0.0)))
            .collect();
        painter.add(egui::Shape::line(chosen, Stroke::new(1.0, Color32::GRAY)));
        for i in 0..words.len() {
            let points: Vec<Pos2> = steps
                .iter()
                .enumerate()
                .filter_map(|(k, s)| {
                    let w = s.attention.as_ref()?.words.get(i)?.weight;
                    Some(at(k, w))
                })
                .collect();
            let color = WORD_COLORS[i % WORD_COLORS.len()];
            painter.add(egui::Shape::line(points, Stroke::new(1.5, color)));
        }
        // A tick at the bottom of every step where the agent did not take the bot's action.
        for (k, s) in steps.iter().enumerate() {
            if s.expert_action.is_some_and(|a| a != s.action) {
                let x = at(k, 0.0).x;
                painter.line_segment(
                    [Pos2::new(x, rect.max.y), Pos2::new(x, rect.max.y - 8.0)],
                    Stroke::new(1.5, super::numbers::EXPERT_LEFT),
                );
            }
        }
        let cursor = self.cursor.step.min(steps.len() - 1);
        let x = at(cursor, 0.0).x;
        painter.line_segment(
            [Pos2::new(x, rect.min.y), Pos2::new(x, rect.max.y)],
            Stroke::new(1.5, Color32::from_rgb(0, 160, 255)),
        );
        painter.text(
            rect.left_top() + Vec2::new(3.0, 2.0),
            egui::Align2::LEFT_TOP,
            "1",
            egui::FontId::proportional(10.0),
            Color32::GRAY,
        );
        if let Some(pos) = resp.interact_pointer_pos()
            && resp.clicked()
        {
            let t = ((pos.x - rect.min.x) / rect.width()).clamp(0.0, 1.0);
            self.cursor.step = (t * last).round() as usize;
        }
    }
}
