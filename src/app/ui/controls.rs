//! The top bar: checkpoint (and compare mode), level, seed and sampling, run; the mission
//! editor; exports; and the field that opens an evaluation's report.

use std::path::Path;
use std::sync::mpsc::Sender;

use eframe::egui;
use egui::{Color32, Key};

use crate::app::Launch;
use crate::app::screenshot::{Shot, request_shot};
use crate::app::seed::seed_field;
use crate::app::session::{Agent, Export, Session};
use crate::env::edit::Edit;
use crate::env::level::{LevelConfig, LevelId, TaskSet};
use crate::env::vocab;
use crate::episode::ActionMode;

/// The level picker's name for the paper's level (its room, objects and tasks beside it).
const PAPER_LEVEL: &str = "the paper's";

/// The top bar, with the fields that are its own.
pub(super) struct ControlsPanel {
    /// The folder exports go to.
    export_dir: String,
    /// The Rerun viewer to connect to.
    connect_url: String,
    /// The field naming an evaluation's folder.
    report_text: String,
    /// Where the PNG button's picture is sent.
    shots: Sender<Shot>,
}

impl ControlsPanel {
    /// The top bar of a debugger opened with `launch`; the PNG button's pictures go to `shots`.
    pub(super) fn new(launch: &Launch, shots: Sender<Shot>) -> Self {
        Self {
            export_dir: ".".into(),
            connect_url: "rerun+http://127.0.0.1:9876/proxy".into(),
            report_text: launch
                .report
                .as_ref()
                .map_or_else(String::new, |b| b.report.dir.display().to_string()),
            shots,
        }
    }

    /// Draws the bar's two rows.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        ui.horizontal_wrapped(|ui| {
            Self::checkpoints(ui, session);
            ui.separator();
            level_picker(ui, session);
            // A BabyAI level ignores the paper level's room, objects and tasks: they are
            // shown only for the paper's level, where they describe it.
            let level = &mut session.request.level;
            if level.babyai.is_none() {
                ui.label("room");
                ui.add(egui::DragValue::new(&mut level.room_size).range(5..=16));
                ui.label("objects");
                ui.add(egui::DragValue::new(&mut level.n_objects).range(1..=20));
                egui::ComboBox::from_id_salt("tasks")
                    .selected_text(format!("{:?}", level.tasks))
                    .show_ui(ui, |ui| {
                        for t in [TaskSet::Both, TaskSet::GoTo, TaskSet::Pickup] {
                            ui.selectable_value(&mut level.tasks, t, format!("{t:?}"));
                        }
                    });
            }
            ui.label("seed");
            seed_field(ui, &mut session.request.seed);
            let mut sampled = session.request.sampled();
            if ui.checkbox(&mut sampled, "sampled").changed() {
                session.request.mode = if sampled {
                    ActionMode::Sampled
                } else {
                    ActionMode::Greedy
                };
            }
            if ui
                .button("run")
                .on_hover_text("run a fresh episode")
                .clicked()
            {
                if let Err(e) = session.request.level.validate() {
                    session.error(e.to_string());
                } else {
                    session.run_episode();
                }
            }
            if ui.button("next seed").clicked() {
                session.request.seed = session.request.seed.saturating_add(1);
                session.run_episode();
            }
            ui.separator();
            self.report_field(ui, session);
        });
        ui.horizontal_wrapped(|ui| {
            mission_editor(ui, session);
            ui.separator();
            self.exports(ui, session);
        });
    }

    /// The checkpoint field with the bundled names, the compare box and field, and "load".
    fn checkpoints(ui: &mut egui::Ui, session: &mut Session) {
        ui.label("checkpoint");
        checkpoint_field(ui, &mut session.request.checkpoint, CHECKPOINT_FIELD_MIN)
            .on_hover_text("bundled:attention, bundled:baseline, a checkpoint NAME (NAME.json + NAME.safetensors) or an ONNX graph FILE.onnx");
        if let Some(policy) = &session.read_only {
            // The episode shown is no checkpoint's: the field keeps what "load" would load.
            ui.label(
                egui::RichText::new(format!("shown: python policy '{policy}' (read-only)"))
                    .strong(),
            );
        } else if let Some(name) = session.agent.as_ref().and_then(|a| a.acting().model_name()) {
            // An imported graph's own name (groundscope.name), which the path does not show.
            ui.label(egui::RichText::new(name).strong());
        }
        // The bundled names fill the field: one place shows the checkpoint, not two.
        ui.menu_button("bundled…", |ui| {
            for n in crate::policy::bundled::names() {
                if ui.button(n.as_str()).clicked() {
                    session.request.checkpoint.clone_from(&n);
                    ui.close();
                }
            }
        })
        .response
        .on_hover_text("bundled checkpoints");
        ui.checkbox(&mut session.compare, "compare with");
        ui.add_enabled_ui(session.compare, |ui| {
            checkpoint_field(ui, &mut session.compare_text, COMPARE_FIELD_MIN)
        });
        if ui.button("load").clicked() {
            session.load_checkpoints();
        }
    }

    /// The field and button that open an evaluation's report in the episodes panel.
    fn report_field(&mut self, ui: &mut egui::Ui, session: &mut Session) {
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
            session.open_report(Path::new(&dir));
        }
    }

    /// The export folder, the file exports, the PNG of the window and Rerun.
    fn exports(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        ui.label("export to");
        ui.add(egui::TextEdit::singleline(&mut self.export_dir).desired_width(90.0));
        let path = |session: &Session, ext: &str| session.export_path(&self.export_dir, ext);
        if ui.button(".rrd").clicked() {
            let p = path(session, "rrd");
            session.export(Export::Rrd(p));
        }
        if ui.button("MCAP").clicked() {
            let p = path(session, "mcap");
            session.export(Export::Mcap(p));
        }
        if ui.button("GIF").clicked() {
            let p = path(session, "gif");
            session.export(Export::Gif(p));
        }
        if ui
            .button("PNG")
            .on_hover_text("this window, as it is now")
            .clicked()
        {
            let p = path(session, "png");
            request_shot(ui.ctx(), &self.shots, p, false);
        }
        // The viewer URL matters only when connecting: it lives in the menu, not the bar.
        ui.menu_button("Rerun…", |ui| {
            if ui.button("spawn a viewer").clicked() {
                session.export(Export::Spawn);
                ui.close();
            }
            ui.label("or connect to a running one:");
            ui.add(egui::TextEdit::singleline(&mut self.connect_url).desired_width(240.0));
            if ui.button("connect").clicked() {
                session.export(Export::Connect(self.connect_url.clone()));
                ui.close();
            }
        });
    }
}

/// The narrowest the checkpoint field gets, in points: room for `bundled:attention`.
const CHECKPOINT_FIELD_MIN: f32 = 160.0;

/// The narrowest the compared checkpoint's field gets, in points: room for `bundled:baseline`.
const COMPARE_FIELD_MIN: f32 = 140.0;

/// What a field adds to its text's width (its margins and the cursor), in points.
const FIELD_PADDING: f32 = 20.0;

/// The width of a checkpoint field for a name `text_width` points wide, where `room` points
/// are left on the bar's row: the name's own width (at least `min`), and whether it must wrap,
/// a name wider than the row wrapping onto more lines of a field as wide as the row. A fixed
/// 160 points cut "bundled:babyai-grounded" and any path longer than it, in the window and in
/// its screenshots.
fn checkpoint_field_width(text_width: f32, room: f32, min: f32) -> (f32, bool) {
    let want = (text_width + FIELD_PADDING).max(min);
    let room = room.max(min);
    if want <= room {
        (want, false)
    } else {
        (room, true)
    }
}

/// A checkpoint field that shows its whole name, `min` points wide at least
/// ([`checkpoint_field_width`]).
fn checkpoint_field(ui: &mut egui::Ui, text: &mut String, min: f32) -> egui::Response {
    let font = egui::TextStyle::Body.resolve(ui.style());
    let color = ui.visuals().text_color();
    let text_width = ui
        .painter()
        .layout_no_wrap(text.clone(), font, color)
        .size()
        .x;
    let (width, wraps) = checkpoint_field_width(text_width, ui.available_width(), min);
    if !wraps {
        return ui.add(
            egui::TextEdit::singleline(&mut *text)
                .font(egui::TextStyle::Body)
                .desired_width(width),
        );
    }
    let r = ui.add(
        egui::TextEdit::multiline(&mut *text)
            .font(egui::TextStyle::Body)
            .desired_width(width)
            .desired_rows(1),
    );
    // A name has no line breaks: Enter in the wrapping field adds none.
    if r.changed() {
        text.retain(|c| c != '\n');
    }
    r
}

/// The mission field, what in it the model cannot read, and "apply at this step".
fn mission_editor(ui: &mut egui::Ui, session: &mut Session) {
    ui.label("mission");
    let r = ui.add(egui::TextEdit::singleline(&mut session.mission_text).desired_width(260.0));
    // BabyAI's own split ("ball, then" is two words), against the words this model was
    // trained on: the same check the episode itself makes.
    let known = session
        .agent
        .as_ref()
        .map_or(vocab::VOCAB_SIZE, |a| a.acting().known_words());
    let unknown: Vec<String> = vocab::split_words(&session.mission_text)
        .into_iter()
        .filter(|w| vocab::token_id(w).is_none_or(|t| t as usize >= known))
        .collect();
    if !unknown.is_empty() {
        ui.colored_label(
            Color32::from_rgb(230, 60, 60),
            format!("not a word this model knows: {}", unknown.join(", ")),
        )
        .on_hover_text(format!(
            "known words: {}",
            vocab::VOCABULARY[1..known.min(vocab::VOCABULARY.len())].join(" ")
        ));
    }
    let apply = ui
        .add_enabled(unknown.is_empty(), egui::Button::new("apply at this step"))
        .on_hover_text("re-run the policy from the current step with this mission");
    if apply.clicked()
        || (r.lost_focus() && ui.input(|i| i.key_pressed(Key::Enter)) && unknown.is_empty())
    {
        let text = session.mission_text.clone();
        session.probe(&Edit::Mission(text));
    }
}

/// The level: the paper's (its room, objects and tasks beside it) or any registered BabyAI
/// level, run as minigrid registers it unless "done action" is ticked, as
/// `view --level ID [--done]` runs it.
fn level_picker(ui: &mut egui::Ui, session: &mut Session) {
    let level = session.request.level;
    let current = level.babyai.map_or(PAPER_LEVEL, LevelId::id);
    let mut picked = None;
    // The label and its picker as one unit: a wrapping top bar keeps them together.
    ui.horizontal(|ui| {
        ui.label("level");
        egui::ComboBox::from_id_salt("level")
            .selected_text(current)
            .height(420.0)
            .show_ui(ui, |ui| {
                if ui
                    .selectable_label(level.babyai.is_none(), PAPER_LEVEL)
                    .clicked()
                {
                    picked = Some(None);
                }
                for id in LevelId::all() {
                    if ui
                        .selectable_label(level.babyai == Some(id), id.id())
                        .clicked()
                    {
                        picked = Some(Some(id));
                    }
                }
            })
            .response
            .on_hover_text("the paper's level or any of minigrid 3.2.0's 96 BabyAI levels");
    });
    let mut done = level.done_required;
    let toggled = ui
        .checkbox(&mut done, "done action")
        .on_hover_text(
            "the paper's done-action mode: success only on `done` right after the instruction is satisfied (the paper's level uses it; a registered BabyAI id, as gym.make(id), does not)",
        )
        .changed();
    if toggled {
        session.request.level.done_required = done;
        session.run_episode();
        return;
    }
    let Some(choice) = picked else { return };
    let base = session.agent.as_ref().map(Agent::level).unwrap_or_default();
    let picked = match choice {
        Some(id) => LevelConfig::babyai(id, false),
        None if base.babyai.is_none() => base,
        None => LevelConfig::default(),
    };
    if picked != level {
        session.request.level = picked;
        session.mission_text.clear();
        // A model that cannot read the level is replaced first; its episode follows.
        if !session.fallback_where_unreadable() {
            session.run_episode();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{CHECKPOINT_FIELD_MIN, FIELD_PADDING, checkpoint_field_width};

    /// A name gets the field's width it needs, a short one the field's least, and one wider
    /// than the row wraps in a field as wide as the row: never a field narrower than its name.
    #[test]
    fn a_checkpoint_field_is_as_wide_as_its_name() {
        let min = CHECKPOINT_FIELD_MIN;
        assert_eq!(checkpoint_field_width(50.0, 900.0, min), (min, false));
        let (w, wraps) = checkpoint_field_width(400.0, 900.0, min);
        assert!(!wraps && w >= 400.0 + FIELD_PADDING, "{w}");
        assert_eq!(checkpoint_field_width(1500.0, 900.0, min), (900.0, true));
    }
}
