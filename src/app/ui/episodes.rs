//! The episodes panel of an evaluation (`view --report DIR`, or "report…" in the top bar):
//! its episodes filtered and sorted ([`crate::metrics::report::browse`] decides which and in
//! what order), N / P to the next or previous failure, a click to open one at the step where
//! it was lost, and a second checkpoint of the report to compare on the same episode.

use std::path::Path;

use eframe::egui;
use egui::RichText;

use super::Debugger;
use crate::app::session::Agent;
use crate::metrics::report::browse::{Browser, Column, Divergence, Outcome};

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

impl Debugger {
    /// Opens the evaluation in `dir` in the panel, replacing any open one.
    pub fn open_report(&mut self, dir: &Path) {
        match Browser::open(dir) {
            Ok(b) => {
                self.info(format!(
                    "report {}: {} episodes, {} failed (N / P: next / previous failure)",
                    dir.display(),
                    b.rows.len(),
                    b.rows.iter().filter(|r| !r.success).count()
                ));
                self.report = Some(b);
                self.show_episodes = true;
            }
            Err(e) => self.error(e.to_string()),
        }
    }

    /// The report's episodes listed now, in order: what the panel shows.
    pub fn report_rows(&self) -> Vec<usize> {
        self.report
            .as_ref()
            .map_or_else(Vec::new, |b| b.shown().to_vec())
    }

    /// Opens the report's episode `i` (an index into its rows): its checkpoint (loaded if it is
    /// not the one open), level, seed and sampling, at the step where it was lost.
    pub fn open_report_episode(&mut self, i: usize) {
        let Some(b) = self.report.as_mut() else {
            return;
        };
        b.selected = Some(i);
        self.report_scroll = true;
        let ep = match b.episode(i) {
            Ok(ep) => ep,
            Err(e) => return self.error(e.to_string()),
        };
        if self.agent.as_ref().is_none_or(|a| a.spec != ep.checkpoint) {
            match Agent::load(&ep.checkpoint) {
                Ok(a) => self.agent = Some(a),
                Err(e) => return self.error(format!("{}: {e}", ep.checkpoint)),
            }
        }
        self.checkpoint_text.clone_from(&ep.checkpoint);
        self.level = ep.level;
        self.seed = ep.seed;
        self.sample = ep.sample;
        self.mission_text.clear();
        self.pending_step = Some(ep.step);
        self.run_episode(None);
    }

    /// Goes to the next (or previous) failure listed and opens it.
    pub fn step_report_failure(&mut self, forward: bool) {
        let Some(b) = self.report.as_mut() else {
            return;
        };
        match b.step_failure(forward) {
            Some(i) => self.open_report_episode(i),
            None => self.info("no failure among the episodes listed"),
        }
    }

    /// The top bar's "report…" field and button, and the toggle of the panel.
    pub(super) fn report_controls(&mut self, ui: &mut egui::Ui) {
        ui.add(
            egui::TextEdit::singleline(&mut self.report_text)
                .hint_text("eval --out DIR")
                .desired_width(120.0),
        )
        .on_hover_text(
            "an evaluation's folder (groundscope eval --out DIR): its episodes to browse",
        );
        if ui.button("report…").clicked() {
            let dir = self.report_text.trim().to_owned();
            self.open_report(Path::new(&dir));
        }
        if self.report.is_some() {
            ui.toggle_value(&mut self.show_episodes, "episodes");
        }
    }

    /// The episodes window.
    pub(super) fn episodes_window(&mut self, ctx: &egui::Context) {
        if self.report.is_none() || !self.show_episodes {
            return;
        }
        let mut open = self.show_episodes;
        let mut clicked = None;
        let mut compare_with = None;
        let current = self.agent.as_ref().map(|a| a.spec.clone());
        // The row opened by a key or at start is brought into view once.
        let scroll = std::mem::take(&mut self.report_scroll);
        let title = self
            .report
            .as_ref()
            .map_or_else(String::new, |b| format!("episodes of {}", b.dir.display()));
        egui::Window::new(title)
            .id(egui::Id::unique("episodes"))
            .open(&mut open)
            .default_size([760.0, 360.0])
            .default_pos([ctx.content_rect().right() - 780.0, 120.0])
            .show(ctx, |ui| {
                let Some(b) = self.report.as_mut() else {
                    return;
                };
                Self::filters(ui, b);
                let checkpoints = b.values(Column::Checkpoint);
                if checkpoints.len() > 1 {
                    ui.horizontal(|ui| {
                        ui.label("compare with");
                        for c in checkpoints
                            .iter()
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
                clicked = Self::table(ui, b, scroll);
            });
        self.show_episodes = open;
        if let Some(c) = compare_with {
            self.compare_text = c;
            self.compare = true;
            match Agent::load(self.compare_text.trim()) {
                Ok(a) => self.compare_agent = Some(a),
                Err(e) => self.error(format!("compare: {e}")),
            }
            if let Some(i) = self.report.as_ref().and_then(|b| b.selected) {
                self.open_report_episode(i);
            } else {
                self.run_episode(None);
            }
        }
        if let Some(i) = clicked {
            self.open_report_episode(i);
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
        ui.label(format!(
            "{} of {} episodes listed, {} failed",
            shown.len(),
            b.rows.len(),
            shown.iter().filter(|&&i| !b.rows[i].success).count()
        ));
        let mut sort = None;
        egui::ScrollArea::horizontal()
            .show(ui, |ui| {
                ui.horizontal(|ui| {
                    for col in Column::ALL {
                        let arrow = match b.sort {
                            Some((c, true)) if c == col => " ▲",
                            Some((c, false)) if c == col => " ▼",
                            _ => "",
                        };
                        let r = ui.add_sized(
                            [width(col), 18.0],
                            egui::Button::new(
                                RichText::new(format!("{}{arrow}", col.name())).strong(),
                            ),
                        );
                        if r.on_hover_text("sort by this column").clicked() {
                            sort = Some(col);
                        }
                    }
                });
                let row_height = ui.text_style_height(&egui::TextStyle::Body) + 4.0;
                let mut clicked = None;
                let mut area = egui::ScrollArea::vertical();
                let at = b.selected.and_then(|s| shown.iter().position(|&i| i == s));
                if let (true, Some(at)) = (scroll, at) {
                    let spacing = ui.spacing().item_spacing.y;
                    area = area.vertical_scroll_offset(at as f32 * (row_height + spacing));
                }
                area.show_rows(ui, row_height, shown.len(), |ui, range| {
                    for &i in &shown[range] {
                        let row = &b.rows[i];
                        let selected = b.selected == Some(i);
                        ui.horizontal(|ui| {
                            for col in Column::ALL {
                                let mut text = RichText::new(col.cell(row));
                                if col == Column::Outcome && !row.success {
                                    text = text.color(super::numbers::FAILED);
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
                if let Some(col) = sort {
                    b.sort_by(col);
                }
                clicked
            })
            .inner
    }
}
