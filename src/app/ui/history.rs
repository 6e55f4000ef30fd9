//! The episode plot, the episode at a glance under the step's panels: each word's weight w
//! and the chosen action's probability over every step, with the cursor; a click moves the
//! cursor there.

use eframe::egui;
use egui::{Align2, Color32, FontId, Pos2, Rect, Sense, Stroke, Vec2};

use crate::app::numbers::EXPERT_LEFT;
use crate::app::session::Session;

/// Line colours of the words, in mission order (repeating past the end); chosen off the
/// viridis ramp's dark end so that they read on the dark panel, and without orange, which
/// means a grounding mark "only nearby".
const WORD_COLORS: [Color32; 6] = [
    Color32::from_rgb(86, 180, 233),
    Color32::from_rgb(170, 140, 255),
    Color32::from_rgb(0, 158, 115),
    Color32::from_rgb(204, 121, 167),
    Color32::from_rgb(240, 228, 66),
    Color32::from_rgb(0, 114, 178),
];

/// The episode plot, at the foot of the centre column.
#[derive(Default)]
pub(super) struct HistoryPanel {
    /// How tall the plot is, in points (set by the layout each frame; what the legend leaves
    /// of it, at least 70).
    pub(super) height: f32,
}

impl HistoryPanel {
    /// Draws the plot across the available width; a click moves the cursor to that step.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        let Some(shown) = session.shown.clone() else {
            return;
        };
        let steps = &shown.trace.steps;
        if steps.is_empty() {
            return;
        }
        let all: Vec<String> = steps
            .first()
            .and_then(|s| s.attention.as_ref())
            .map(|a| a.words.iter().map(|w| w.word.clone()).collect())
            .unwrap_or_default();
        // The words whose maps are shown: with function words folded, their lines leave the
        // plot and the legend too (one colour would otherwise stand for several words).
        let roles = steps
            .first()
            .map(|s| crate::env::roles::roles_of(&s.world))
            .unwrap_or_default();
        let folds = session.selection.folded(&roles, all.len());
        let words: Vec<(usize, &String)> = all
            .iter()
            .enumerate()
            .filter(|&(i, _)| !folds.get(i).copied().unwrap_or(false))
            .collect();
        ui.horizontal_wrapped(|ui| {
            ui.label("over the episode:");
            for (n, (_, w)) in words.iter().enumerate() {
                ui.colored_label(WORD_COLORS[n % WORD_COLORS.len()], format!("w of {w}"));
            }
            if words.len() < all.len() {
                ui.weak("(function words folded)");
            }
            ui.colored_label(Color32::GRAY, "p of the chosen action");
            ui.colored_label(EXPERT_LEFT, "| left the expert's plan");
        });
        // What the legend above left of the column, so that the step axis stays on screen
        // however many lines the legend took.
        let height = self.height.min(ui.available_height() - 6.0).max(70.0);
        let width = ui.available_width().max(100.0);
        let (outer, resp) = ui.allocate_exact_size(Vec2::new(width, height), Sense::click());
        resp.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, "episode plot"));
        // The plot itself, inside margins for the axes' tick labels.
        let rect = Rect::from_min_max(
            outer.min + Vec2::new(AXIS_LEFT, 2.0),
            outer.max - Vec2::new(4.0, AXIS_BOTTOM),
        );
        let painter = ui.painter_at(outer);
        painter.rect_filled(rect, 2.0, ui.visuals().extreme_bg_color);
        let last = steps.len().saturating_sub(1).max(1) as f32;
        axes(&painter, rect, last, ui.visuals().weak_text_color());
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
        for (n, &(i, _)) in words.iter().enumerate() {
            let points: Vec<Pos2> = steps
                .iter()
                .enumerate()
                .filter_map(|(k, s)| {
                    let w = s.attention.as_ref()?.words.get(i)?.weight;
                    Some(at(k, w))
                })
                .collect();
            let color = WORD_COLORS[n % WORD_COLORS.len()];
            painter.add(egui::Shape::line(points, Stroke::new(1.5, color)));
        }
        // A tick at the bottom of every step where the agent did not take the bot's action.
        for (k, s) in steps.iter().enumerate() {
            if s.expert_action.is_some_and(|a| a != s.action) {
                let x = at(k, 0.0).x;
                painter.line_segment(
                    [Pos2::new(x, rect.max.y), Pos2::new(x, rect.max.y - 8.0)],
                    Stroke::new(1.5, EXPERT_LEFT),
                );
            }
        }
        let cursor = session.cursor.step.min(steps.len() - 1);
        let x = at(cursor, 0.0).x;
        painter.line_segment(
            [Pos2::new(x, rect.min.y), Pos2::new(x, rect.max.y)],
            Stroke::new(1.5, Color32::from_rgb(0, 160, 255)),
        );
        if let Some(pos) = resp.interact_pointer_pos()
            && resp.clicked()
        {
            let t = ((pos.x - rect.min.x) / rect.width()).clamp(0.0, 1.0);
            session.cursor.step = (t * last).round() as usize;
        }
    }
}

/// Width left of the plot for the value axis's labels.
const AXIS_LEFT: f32 = 26.0;

/// Height under the plot for the step axis's labels.
const AXIS_BOTTOM: f32 = 15.0;

/// A step between ticks that is 1, 2 or 5 times a power of ten and gives at most about
/// `most` ticks over `0..=last`.
fn tick_step(last: f32, most: f32) -> f32 {
    let raw = (last / most.max(1.0)).max(1.0);
    let power = 10f32.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * power)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * power)
}

/// The axes' ticks and labels: w and p from 0 to 1 on the left, steps below, with faint grid
/// lines across the plot.
fn axes(painter: &egui::Painter, rect: Rect, last: f32, color: Color32) {
    let font = FontId::proportional(11.0);
    let grid = Stroke::new(1.0, color.gamma_multiply(0.25));
    let tick = Stroke::new(1.0, color);
    for v in [0.0, 0.5, 1.0] {
        let y = rect.max.y - rect.height() * v;
        painter.line_segment([Pos2::new(rect.min.x, y), Pos2::new(rect.max.x, y)], grid);
        painter.line_segment(
            [Pos2::new(rect.min.x - 4.0, y), Pos2::new(rect.min.x, y)],
            tick,
        );
        painter.text(
            Pos2::new(rect.min.x - 6.0, y),
            Align2::RIGHT_CENTER,
            format!("{v}"),
            font.clone(),
            color,
        );
    }
    // About one label every 70 points, so that they never touch.
    let step = tick_step(last, rect.width() / 70.0);
    let mut k = 0.0;
    while k <= last + 0.5 {
        let x = rect.min.x + rect.width() * k / last;
        painter.line_segment(
            [Pos2::new(x, rect.max.y), Pos2::new(x, rect.max.y + 4.0)],
            tick,
        );
        // The axis's name takes the right end.
        if x < rect.max.x - 36.0 {
            painter.text(
                Pos2::new(x, rect.max.y + 3.0),
                Align2::CENTER_TOP,
                format!("{k}"),
                font.clone(),
                color,
            );
        }
        k += step;
    }
    painter.text(
        Pos2::new(rect.max.x, rect.max.y + 3.0),
        Align2::RIGHT_TOP,
        "step",
        font,
        color,
    );
}

#[cfg(test)]
mod tests {
    use super::tick_step;

    /// Whether `c` reads as orange: a saturated, bright hue between 15° and 45°.
    fn orange([r, g, b]: [u8; 3]) -> bool {
        let (r, g, b) = (f32::from(r), f32::from(g), f32::from(b));
        let (max, min) = (r.max(g).max(b), r.min(g).min(b));
        if max - min < 1.0 || max < 150.0 {
            return false;
        }
        let hue = if max == r {
            60.0 * ((g - b) / (max - min)).rem_euclid(6.0)
        } else if max == g {
            60.0 * ((b - r) / (max - min) + 2.0)
        } else {
            60.0 * ((r - g) / (max - min) + 4.0)
        };
        (15.0..=45.0).contains(&hue) && (max - min) / max > 0.5
    }

    /// Orange means one thing: of the debugger's and the Rerun recording's named colours only
    /// the grounding mark "only nearby" is orange (the highlighted bars, in both, the failure
    /// text and the word lines were too).
    #[test]
    fn orange_means_one_thing() {
        use crate::render::palette;
        let rgb = |c: eframe::egui::Color32| [c.r(), c.g(), c.b()];
        let ui = super::WORD_COLORS.iter().map(|&c| rgb(c)).chain(
            [
                crate::app::numbers::HIGHLIGHT,
                crate::app::numbers::FAILED,
                crate::app::numbers::EXPERT_LEFT,
            ]
            .map(rgb),
        );
        let marks = [
            palette::GROUNDING_HIT,
            palette::GROUNDING_MISS,
            palette::TARGET,
            palette::TRAIL,
            palette::CLAUSE_DONE,
            palette::CLAUSE_LATER,
            palette::CHOSEN_BAR,
            palette::BAR,
        ];
        for c in ui.chain(marks) {
            assert!(!orange(c), "{c:?} is orange");
        }
        assert!(orange(palette::GROUNDING_NEAR));
        assert!(orange([255, 150, 40]), "the old highlight");
    }

    #[test]
    fn ticks_are_round_and_few() {
        assert_eq!(tick_step(8.0, 10.0), 1.0);
        assert_eq!(tick_step(69.0, 10.0), 10.0);
        assert_eq!(tick_step(1727.0, 15.0), 200.0);
        assert_eq!(tick_step(30.0, 20.0), 2.0);
        assert!(1727.0 / tick_step(1727.0, 15.0) <= 15.0);
    }
}
