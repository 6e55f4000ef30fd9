//! The episodes panel of an evaluation (`view --report DIR`, or "report…" in the top bar),
//! docked under the top bar: its episodes filtered and sorted ([`crate::app::episodes`]
//! decides which and in what order), N / P to the next or previous failure, a click to open
//! one at the step where it was lost — the list then folds to one line, out of the way of the
//! episode it opened — and a second checkpoint of the report to compare on the same episode.

use eframe::egui;
use egui::RichText;

use crate::app::episodes::{Browser, Column, Divergence, Outcome};
use crate::app::numbers::FAILED;
use crate::app::session::Session;

/// The mark of an ascending sort. Plain text: egui's default proportional font (Ubuntu
/// Light) has neither "▲" nor "⏶", which drew as empty boxes (a unit test holds the marks to
/// the font).
const ASCENDING: &str = "^";

/// The mark of a descending sort (see [`ASCENDING`]).
const DESCENDING: &str = "v";

/// The height the list of rows scrolls within, in points: about eight rows, so that the
/// panel leaves the step it opens most of the window.
const ROWS_HEIGHT: f32 = 180.0;

/// Width of each column, in points (level ids are long; the checkpoint last takes the rest).
fn width(col: Column) -> f32 {
    match col {
        Column::Level => 190.0,
        Column::Class | Column::Behaviour => 130.0,
        Column::Checkpoint => 160.0,
        Column::Outcome => 60.0,
        Column::Seed => 90.0,
        _ => 52.0,
    }
}

/// A choice among `values` for a filter, "any" for `None`; true when it changed.
fn choice(ui: &mut egui::Ui, label: &str, value: &mut Option<String>, values: &[String]) -> bool {
    let before = value.clone();
    ui.label(label);
    egui::ComboBox::from_id_salt(label)
        .selected_text(value.as_deref().unwrap_or("any"))
        .width(150.0)
        .show_ui(ui, |ui| {
            ui.selectable_value(value, None, "any");
            for v in values {
                ui.selectable_value(value, Some(v.clone()), v);
            }
        });
    *value != before
}

/// The episodes panel; the evaluation and what it lists are the session's.
#[derive(Default)]
pub(super) struct EpisodesPanel {
    /// The row last brought into view: one selected since (by a key, a click or at start)
    /// is scrolled to once, when the list is shown.
    revealed: Option<usize>,
}

impl EpisodesPanel {
    /// Draws the panel's line (the "episodes" toggle, the report's folder and, folded, what
    /// it holds) and, when listed, the filters, "compare with" and the rows.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        let current = session.agent.as_ref().map(|a| a.spec.clone());
        let Some(b) = session.report.as_mut() else {
            return;
        };
        let mut compare_with = None;
        ui.horizontal(|ui| {
            let hover = if b.listed {
                "fold the list"
            } else {
                "list the episodes"
            };
            ui.toggle_value(&mut b.listed, "episodes")
                .on_hover_text(hover);
            ui.label(RichText::new(b.report.dir.display().to_string()).strong());
            if !b.listed {
                ui.label(
                    RichText::new(format!(
                        "{} of {} failed · N / P: next / previous failure",
                        b.failed(),
                        b.report.rows.len()
                    ))
                    .weak(),
                );
            }
        });
        if !b.listed {
            return;
        }
        filters(ui, b);
        // A Python policy is no checkpoint to run beside another (a policy named `bot` is not
        // minigrid's bot).
        let all = b.values(Column::Checkpoint);
        let checkpoints: Vec<&String> = all
            .iter()
            .filter(|c| !b.report.python.contains(*c))
            .collect();
        if all.len() > 1 && !checkpoints.is_empty() {
            ui.horizontal(|ui| {
                ui.label("compare with");
                for c in checkpoints
                    .iter()
                    .copied()
                    .filter(|c| current.as_deref() != Some(c.as_str()))
                {
                    if ui
                        .button(c)
                        .on_hover_text("run it on the same episode, side by side")
                        .clicked()
                    {
                        compare_with = Some(c.clone());
                    }
                }
            });
        }
        ui.separator();
        // The row opened by a key, a click or at start is brought into view once.
        let scroll = b.selected.is_some() && b.selected != self.revealed;
        self.revealed = b.selected;
        let picked = table(ui, b, scroll);
        if let Some(c) = compare_with {
            session.compare_report_with(c);
        }
        if let Some(i) = picked {
            session.pick_report_episode(i);
        }
    }
}

/// The filter choices over the report's values.
fn filters(ui: &mut egui::Ui, b: &mut Browser) {
    let mut changed = false;
    ui.horizontal_wrapped(|ui| {
        let levels = b.values(Column::Level);
        changed |= choice(ui, "level", &mut b.filter.level, &levels);
        let before = b.filter.outcome;
        ui.label("outcome");
        egui::ComboBox::from_id_salt("outcome")
            .selected_text(match b.filter.outcome {
                Outcome::All => "any",
                Outcome::Failures => "failures",
                Outcome::Successes => "successes",
            })
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut b.filter.outcome, Outcome::All, "any");
                ui.selectable_value(&mut b.filter.outcome, Outcome::Failures, "failures");
                ui.selectable_value(&mut b.filter.outcome, Outcome::Successes, "successes");
            });
        changed |= b.filter.outcome != before;
        let classes = b.values(Column::Class);
        changed |= choice(ui, "class", &mut b.filter.class, &classes);
        let behaviours = b.values(Column::Behaviour);
        changed |= choice(ui, "behaviour", &mut b.filter.behaviour, &behaviours);
        let before = b.filter.divergence;
        ui.label("diverged from the bot");
        egui::ComboBox::from_id_salt("diverged")
            .selected_text(match b.filter.divergence {
                Divergence::All => "any",
                Divergence::Diverged => "yes",
                Divergence::Never => "never",
            })
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut b.filter.divergence, Divergence::All, "any");
                ui.selectable_value(&mut b.filter.divergence, Divergence::Diverged, "yes");
                ui.selectable_value(&mut b.filter.divergence, Divergence::Never, "never");
            });
        changed |= b.filter.divergence != before;
        let checkpoints = b.values(Column::Checkpoint);
        if checkpoints.len() > 1 {
            changed |= choice(ui, "checkpoint", &mut b.filter.checkpoint, &checkpoints);
        }
    });
    if changed {
        b.refresh();
    }
}

/// The header (a click sorts) and the rows listed (a click opens); returns the row clicked.
fn table(ui: &mut egui::Ui, b: &mut Browser, scroll: bool) -> Option<usize> {
    let shown = b.shown().to_vec();
    let rows = &b.report.rows;
    ui.label(format!(
        "{} of {} episodes listed, {} failed",
        shown.len(),
        rows.len(),
        shown.iter().filter(|&&i| !rows[i].success).count()
    ));
    let mut sort = None;
    let clicked = egui::ScrollArea::horizontal()
        .show(ui, |ui| {
            ui.horizontal(|ui| {
                for col in Column::ALL {
                    let mark = match b.sort {
                        Some((c, true)) if c == col => format!(" {ASCENDING}"),
                        Some((c, false)) if c == col => format!(" {DESCENDING}"),
                        _ => String::new(),
                    };
                    let r = ui.add_sized(
                        [width(col), 18.0],
                        egui::Button::new(RichText::new(format!("{}{mark}", col.name())).strong()),
                    );
                    if r.on_hover_text("sort by this column").clicked() {
                        sort = Some(col);
                    }
                }
            });
            let row_height = ui.text_style_height(&egui::TextStyle::Body) + 4.0;
            let mut clicked = None;
            let mut area = egui::ScrollArea::vertical().max_height(ROWS_HEIGHT);
            let at = b.selected.and_then(|s| shown.iter().position(|&i| i == s));
            if let (true, Some(at)) = (scroll, at) {
                let spacing = ui.spacing().item_spacing.y;
                area = area.vertical_scroll_offset(at as f32 * (row_height + spacing));
            }
            area.show_rows(ui, row_height, shown.len(), |ui, range| {
                for &i in &shown[range] {
                    let row = &b.report.rows[i];
                    let selected = b.selected == Some(i);
                    ui.horizontal(|ui| {
                        for col in Column::ALL {
                            let mut text = RichText::new(col.cell(row));
                            if col == Column::Outcome && !row.success {
                                text = text.color(FAILED);
                            }
                            let r = ui
                                .add_sized(
                                    [width(col), row_height],
                                    egui::Button::selectable(selected, text),
                                )
                                .on_hover_text(&row.mission);
                            if r.clicked() {
                                clicked = Some(i);
                            }
                        }
                    });
                }
            });
            clicked
        })
        .inner;
    if let Some(col) = sort {
        b.sort_by(col);
    }
    clicked
}

#[cfg(test)]
mod tests {
    use super::{ASCENDING, DESCENDING};
    use eframe::egui;

    /// The sort marks are glyphs of egui's default proportional font; "▲", which the header
    /// used, is not (it drew as an empty box).
    #[test]
    fn the_sort_marks_are_in_the_default_font() {
        let ctx = egui::Context::default();
        let _ = ctx.run_ui(egui::RawInput::default(), |_| {});
        let font = egui::FontId::proportional(14.0);
        ctx.fonts_mut(|f| {
            for mark in [ASCENDING, DESCENDING] {
                assert!(f.has_glyphs(&font, mark), "{mark:?}");
            }
            assert!(!f.has_glyphs(&font, "▲"));
        });
    }
}
