//! The instruction as a tree (which clause the verifier waits on, which are done or later,
//! each clause's targets and where they are), the doors and their states, and the clause
//! numbers on the world picture: all read from [`InstructionTree`], as the recordings are.

use eframe::egui;
use egui::{Color32, FontId, Painter, Rect, RichText, Stroke, StrokeKind};

use crate::env::Pos;
use crate::env::tree::{InstructionTree, Stage, doors_text, targets_text};
use crate::record::scene::{ClauseMark, stage_color};
use crate::render::palette::Rgb;

/// A palette colour as egui's.
pub(in crate::app) const fn color32([r, g, b]: Rgb) -> Color32 {
    Color32::from_rgb(r, g, b)
}

/// The step's instruction tree, one row per sequence or clause, indented by depth; then the
/// doors.
pub(in crate::app) fn tree_ui(ui: &mut egui::Ui, tree: &InstructionTree) {
    for n in &tree.nodes {
        // Wrapped, at the normal text size: a long clause's targets stay in the panel.
        ui.horizontal_wrapped(|ui| {
            ui.add_space(18.0 * n.depth as f32);
            ui.label(
                RichText::new(n.stage.name())
                    .small()
                    .color(color32(stage_color(n.stage))),
            );
            let text = match n.clause {
                Some(c) => format!("{} · {}", c + 1, n.text),
                None => n.text.clone(),
            };
            let text = match n.stage {
                Stage::Waiting => RichText::new(text).strong(),
                Stage::Done => RichText::new(text).strikethrough().weak(),
                Stage::Later => RichText::new(text).weak(),
            };
            ui.label(text);
            if n.clause.is_some() {
                ui.label(RichText::new(format!("targets: {}", targets_text(&n.targets))).weak())
                    .on_hover_text(
                        "what the clause's description matched at reset, and where it is now; \
                         M is scored on the targets of the clauses waited on",
                    );
            }
        });
    }
    if !tree.doors.is_empty() {
        ui.label(RichText::new(format!("doors: {}", doors_text(&tree.doors))).weak());
    }
}

/// Frames every clause's targets on the world picture in its stage's colour, with the clause
/// numbers written in a free cell beside each ([`ClauseMark::label_at`]), on the side facing
/// the target, where the mission has more than one clause or description.
pub(in crate::app) fn paint_clause_marks(
    painter: &Painter,
    marks: &[ClauseMark],
    cell_rect: impl Fn(Pos) -> Rect,
) {
    for m in marks {
        let color = color32(stage_color(m.stage));
        let r = cell_rect(m.pos);
        painter.rect_stroke(
            r.shrink(1.0),
            0.0,
            Stroke::new(1.5, color),
            StrokeKind::Inside,
        );
        let font = FontId::proportional((r.height() * 0.5).clamp(12.0, 18.0));
        // A dark backing keeps the numbers legible on any tile.
        let galley = painter.layout_no_wrap(m.label.clone(), font, color);
        let at = if m.label_at == m.pos {
            r.left_top() + egui::vec2(2.0, 1.0)
        } else {
            let (dx, dy) = (m.pos.0 - m.label_at.0, m.pos.1 - m.label_at.1);
            let centre = cell_rect(m.label_at).center()
                + egui::vec2(dx as f32, dy as f32) * (r.width() * 0.25);
            centre - galley.size() / 2.0
        };
        painter.rect_filled(
            Rect::from_min_size(at, galley.size()).expand(1.0),
            2.0,
            Color32::from_black_alpha(170),
        );
        painter.galley(at, galley, color);
    }
}
