//! The top bar (checkpoint, level, seed, mission, export), the timeline with the job
//! progress and messages, and the keyboard shortcuts.

use std::sync::atomic::Ordering;

use eframe::egui;
use egui::{Color32, Key};

use super::Debugger;
use crate::app::session::{Agent, Export, Shown, failure_step, next_miss};
use crate::env::edit::Edit;
use crate::env::level::{LevelConfig, LevelId, TaskSet};
use crate::env::vocab;

/// The level picker's name for the paper's level (its room, objects and tasks beside it).
const PAPER_LEVEL: &str = "the paper's";

/// The seed field's text and the seed it was last in step with (kept in egui's memory from
/// frame to frame).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct SeedText {
    seed: u64,
    text: String,
}

impl SeedText {
    /// The field showing `seed`.
    pub(super) fn new(seed: u64) -> Self {
        Self {
            seed,
            text: seed.to_string(),
        }
    }

    /// Shows `seed` again where it was changed elsewhere ("next seed", an episode of a
    /// report); what is being typed for the seed it holds stays.
    pub(super) fn sync(&mut self, seed: u64) {
        if self.seed != seed {
            *self = Self::new(seed);
        }
    }

    /// After an edit: the seed the text now reads as, if it reads as one.
    pub(super) fn edited(&mut self) -> Option<u64> {
        let seed = parse_seed(&self.text)?;
        self.seed = seed;
        Some(seed)
    }

    /// The field left: text that is not the seed goes back to the seed's digits.
    pub(super) fn left(&mut self) {
        if parse_seed(&self.text) != Some(self.seed) {
            self.text = self.seed.to_string();
        }
    }
}

/// A seed as typed: a whole number from 0 to 2⁶⁴ − 1 (spaces around it and `_` between
/// digits allowed), exactly.
pub(super) fn parse_seed(text: &str) -> Option<u64> {
    let digits: String = text.trim().chars().filter(|&c| c != '_').collect();
    if digits.is_empty() || !digits.chars().all(|c| c.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// The seed as a text field, exact for every `u64`: egui's `DragValue` holds its value as an
/// `f64` and rounded seeds above 2⁵³ (`view --seed 9007199254740993` showed …992 and ran
/// it). While the field is edited the seed follows every text that reads as one; left with
/// text that does not, the field shows the seed again.
fn seed_field(ui: &mut egui::Ui, seed: &mut u64) {
    let id = ui.make_persistent_id("seed_text");
    let mut field = ui
        .ctx()
        .data_mut(|d| d.get_temp::<SeedText>(id))
        .unwrap_or_else(|| SeedText::new(*seed));
    field.sync(*seed);
    let r = ui
        .add(egui::TextEdit::singleline(&mut field.text).desired_width(150.0))
        .on_hover_text("the level seed: a whole number from 0 to 18446744073709551615");
    if r.changed()
        && let Some(s) = field.edited()
    {
        *seed = s;
    }
    if r.lost_focus() {
        field.left();
    }
    ui.ctx().data_mut(|d| d.insert_temp(id, field));
}

impl Debugger {
    pub(super) fn keyboard(&mut self, ctx: &egui::Context) {
        let typing = ctx.memory(|m| m.focused().is_some());
        if typing {
            return;
        }
        let len = self.shown.as_ref().map_or(0, Shown::len);
        ctx.input(|i| {
            if i.key_pressed(Key::ArrowRight) {
                self.cursor.nudge(1, len);
            }
            if i.key_pressed(Key::ArrowLeft) {
                self.cursor.nudge(-1, len);
            }
            if i.key_pressed(Key::Space) {
                self.cursor.playing = !self.cursor.playing;
            }
            if i.key_pressed(Key::Home) {
                self.cursor.step = 0;
            }
            if i.key_pressed(Key::End) {
                self.cursor.step = len.saturating_sub(1);
            }
        });
        // The report's next / previous failure (`view --report`).
        let (next, previous) = ctx.input(|i| (i.key_pressed(Key::N), i.key_pressed(Key::P)));
        if self.report.is_some() && (next || previous) {
            self.step_report_failure(next);
        }
    }

    pub(super) fn controls(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            ui.label("checkpoint");
            ui.add(egui::TextEdit::singleline(&mut self.checkpoint_text).desired_width(160.0))
                .on_hover_text("bundled:attention, bundled:baseline, a checkpoint NAME (NAME.json + NAME.safetensors) or an ONNX graph FILE.onnx");
            // An imported graph's own name (groundscope.name), which the path does not show.
            if let Some(name) = self.agent.as_ref().and_then(|a| a.acting().model_name()) {
                ui.label(egui::RichText::new(name).strong());
            }
            // The bundled names fill the field: one place shows the checkpoint, not two.
            ui.menu_button("bundled…", |ui| {
                for n in crate::policy::bundled::names() {
                    if ui.button(n.as_str()).clicked() {
                        self.checkpoint_text.clone_from(&n);
                        ui.close();
                    }
                }
            })
            .response
            .on_hover_text("bundled checkpoints");
            ui.checkbox(&mut self.compare, "compare with");
            ui.add_enabled(
                self.compare,
                egui::TextEdit::singleline(&mut self.compare_text).desired_width(140.0),
            );
            if ui.button("load").clicked() {
                self.load_checkpoints();
            }
            ui.separator();
            self.level_picker(ui);
            // A BabyAI level ignores the paper level's room, objects and tasks: they are
            // shown only for the paper's level, where they describe it.
            if self.level.babyai.is_none() {
                ui.label("room");
                ui.add(egui::DragValue::new(&mut self.level.room_size).range(5..=16));
                ui.label("objects");
                ui.add(egui::DragValue::new(&mut self.level.n_objects).range(1..=20));
                egui::ComboBox::from_id_salt("tasks")
                    .selected_text(format!("{:?}", self.level.tasks))
                    .show_ui(ui, |ui| {
                        for t in [TaskSet::Both, TaskSet::GoTo, TaskSet::Pickup] {
                            ui.selectable_value(&mut self.level.tasks, t, format!("{t:?}"));
                        }
                    });
            }
            ui.label("seed");
            seed_field(ui, &mut self.seed);
            ui.checkbox(&mut self.sample, "sampled");
            if ui.button("run").on_hover_text("run a fresh episode").clicked() {
                if let Err(e) = self.level.validate() {
                    self.error(e.to_string());
                } else {
                    self.run_episode(None);
                }
            }
            if ui.button("next seed").clicked() {
                self.seed = self.seed.saturating_add(1);
                self.run_episode(None);
            }
            ui.separator();
            self.report_controls(ui);
        });
        ui.horizontal_wrapped(|ui| {
            ui.label("mission");
            let r = ui.add(egui::TextEdit::singleline(&mut self.mission_text).desired_width(260.0));
            // BabyAI's own split ("ball, then" is two words), against the words this model
            // was trained on: the same check the episode itself makes.
            let known = self
                .agent
                .as_ref()
                .map_or(vocab::VOCAB_SIZE, |a| a.acting().known_words());
            let unknown: Vec<String> = vocab::split_words(&self.mission_text)
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
                let text = self.mission_text.clone();
                self.probe(&Edit::Mission(text));
            }
            ui.separator();
            ui.label("export to");
            ui.add(egui::TextEdit::singleline(&mut self.export_dir).desired_width(90.0));
            if ui.button(".rrd").clicked() {
                self.export(Export::Rrd(self.export_path("rrd")));
            }
            if ui.button("MCAP").clicked() {
                self.export(Export::Mcap(self.export_path("mcap")));
            }
            if ui.button("GIF").clicked() {
                self.export(Export::Gif(self.export_path("gif")));
            }
            if ui
                .button("PNG")
                .on_hover_text("this window, as it is now")
                .clicked()
            {
                let p = self.export_path("png");
                self.request_shot(ui.ctx(), p, false);
            }
            // The viewer URL matters only when connecting: it lives in the menu, not the bar.
            ui.menu_button("Rerun…", |ui| {
                if ui.button("spawn a viewer").clicked() {
                    self.export(Export::Spawn);
                    ui.close();
                }
                ui.label("or connect to a running one:");
                ui.add(egui::TextEdit::singleline(&mut self.connect_url).desired_width(240.0));
                if ui.button("connect").clicked() {
                    self.export(Export::Connect(self.connect_url.clone()));
                    ui.close();
                }
            });
        });
    }

    /// The level: the paper's (its room, objects and tasks beside it) or any registered
    /// BabyAI level, run as minigrid registers it unless "done action" is ticked, as
    /// `view --level ID [--done]` runs it.
    fn level_picker(&mut self, ui: &mut egui::Ui) {
        let current = self.level.babyai.map_or(PAPER_LEVEL, LevelId::id);
        let mut picked = None;
        // The label and its picker as one unit: a wrapping top bar keeps them together.
        ui.horizontal(|ui| {
            ui.label("level");
            egui::ComboBox::from_id_salt("level")
                .selected_text(current)
                .height(420.0)
                .show_ui(ui, |ui| {
                    if ui
                        .selectable_label(self.level.babyai.is_none(), PAPER_LEVEL)
                        .clicked()
                    {
                        picked = Some(None);
                    }
                    for id in LevelId::all() {
                        if ui
                            .selectable_label(self.level.babyai == Some(id), id.id())
                            .clicked()
                        {
                            picked = Some(Some(id));
                        }
                    }
                })
                .response
                .on_hover_text("the paper's level or any of minigrid 3.2.0's 96 BabyAI levels");
        });
        let mut done = self.level.done_required;
        let toggled = ui
            .checkbox(&mut done, "done action")
            .on_hover_text(
                "the paper's done-action mode: success only on `done` right after the instruction is satisfied (the paper's level uses it; a registered BabyAI id, as gym.make(id), does not)",
            )
            .changed();
        if toggled {
            self.level.done_required = done;
            self.run_episode(None);
            return;
        }
        let Some(choice) = picked else { return };
        let base = self.agent.as_ref().map(Agent::level).unwrap_or_default();
        let level = match choice {
            Some(id) => LevelConfig::babyai(id, false),
            None if base.babyai.is_none() => base,
            None => LevelConfig::default(),
        };
        if level != self.level {
            self.level = level;
            self.mission_text.clear();
            self.fallback_where_unreadable();
            self.run_episode(None);
        }
    }

    /// Where the loaded agent cannot read the picked level's mission (a word it was not
    /// trained on), `bundled:babyai` acts instead — or minigrid's bot where even it cannot —
    /// and the message bar says so.
    fn fallback_where_unreadable(&mut self) {
        let Some(agent) = &self.agent else { return };
        let Ok(world) = self.level.generate(self.seed) else {
            return;
        };
        let reads = |a: &Agent| {
            crate::policy::acting::world_tokens(a.policy.acting(), &world, || {
                self.level.to_string()
            })
        };
        let Err(e) = reads(agent) else { return };
        let babyai = Agent::load(crate::policy::bundled::BABYAI)
            .ok()
            .filter(|b| reads(b).is_ok());
        let (fallback, what) = match babyai {
            Some(b) => (Ok(b), "the bundled BabyAI model"),
            None => (
                Agent::load(crate::policy::acting::BOT),
                "minigrid's bot (checkpoint \"bot\")",
            ),
        };
        match fallback {
            Ok(next) => {
                self.info(format!(
                    "{} cannot read this level ({e}): running {what} instead",
                    agent.spec
                ));
                self.checkpoint_text.clone_from(&next.spec);
                self.agent = Some(next);
            }
            Err(e) => self.error(e),
        }
    }

    pub(super) fn timeline(&mut self, ui: &mut egui::Ui) {
        let len = self.shown.as_ref().map_or(0, Shown::len);
        ui.horizontal(|ui| {
            if ui.button("|<").on_hover_text("first step (Home)").clicked() {
                self.cursor.step = 0;
            }
            if ui.button("<").on_hover_text("step back (←)").clicked() {
                self.cursor.nudge(-1, len);
            }
            let play = if self.cursor.playing { "pause" } else { "play" };
            if ui
                .button(play)
                .on_hover_text("play / pause (space)")
                .clicked()
            {
                self.cursor.playing = !self.cursor.playing;
            }
            if ui.button(">").on_hover_text("step forward (→)").clicked() {
                self.cursor.nudge(1, len);
            }
            if ui.button(">|").on_hover_text("last step (End)").clicked() {
                self.cursor.step = len.saturating_sub(1);
            }
            let mut s = self.cursor.step;
            ui.add(
                egui::Slider::new(&mut s, 0..=len.saturating_sub(1))
                    .text(format!("of 0–{}", len.saturating_sub(1))),
            );
            self.cursor.step = s;
            ui.add(egui::Slider::new(&mut self.cursor.speed, 0.5..=20.0).text("steps/s"));
            if let Some(shown) = &self.shown {
                if ui.button("next grounding miss").clicked() {
                    match next_miss(shown, self.cursor.step) {
                        Some(i) => self.cursor.step = i,
                        None => self
                            .messages
                            .push((false, "no grounding miss in this episode".into())),
                    }
                }
                let fail = failure_step(&shown.trace).filter(|_| shown.is_complete());
                if ui
                    .add_enabled(fail.is_some(), egui::Button::new("failure"))
                    .clicked()
                    && let Some(i) = fail
                {
                    self.cursor.step = i;
                }
                // Where it was lost: the step `eval`'s report opens it at
                // (docs/evaluation.md#the-decisive-step).
                if let Some(i) = shown.decisive
                    && ui
                        .button(format!("decisive step {i}"))
                        .on_hover_text(
                            "where the episode was lost: the act its MiniGrid class or its \
                             behaviour names, else the first step it left the bot's plan at a \
                             cost, else its last",
                        )
                        .clicked()
                {
                    self.cursor.step = i;
                }
                // Why it failed: the class and behaviour `eval` gives the same episode
                // (docs/evaluation.md#failure-classes); a MiniGrid class in its own terms
                // ("stepped into lava").
                if let Some(d) = &shown.failure {
                    let behaviour = d
                        .behaviour
                        .map_or_else(String::new, |b| format!(" · {}", b.name()));
                    ui.label(
                        egui::RichText::new(format!("failed: {}{behaviour}", d.class.shown()))
                            .color(super::numbers::FAILED),
                    )
                    .on_hover_text(format!(
                        "class {}; behaviour {}; target in view at {} step(s); M on it at {}",
                        d.class.name(),
                        d.behaviour.map_or("none", |b| b.name()),
                        d.target_visible_steps,
                        d.m_on_target_steps
                            .map_or_else(|| "– (no M)".to_owned(), |n| n.to_string())
                    ));
                }
            }
        });
        ui.horizontal(|ui| {
            for job in &self.jobs {
                ui.spinner();
                if job.total > 0 {
                    let d = job.done.load(Ordering::Relaxed);
                    ui.add(
                        egui::ProgressBar::new(d as f32 / job.total as f32)
                            .desired_width(160.0)
                            .text(format!("{} {d}/{}", job.what, job.total)),
                    );
                } else {
                    ui.label(&job.what);
                }
            }
            if !self.jobs.is_empty() && ui.button("cancel").clicked() {
                self.cancel.store(true, Ordering::Relaxed);
            }
            if let Some((err, m)) = self.messages.last() {
                let color = if *err {
                    Color32::from_rgb(230, 60, 60)
                } else {
                    ui.visuals().weak_text_color()
                };
                ui.colored_label(color, m);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::{SeedText, parse_seed};

    #[test]
    fn every_u64_seed_reads_back_exactly() {
        // Above 2⁵³ an f64 rounds: 2⁵³ + 1 used to show and run as 2⁵³.
        for seed in [
            0,
            7,
            (1 << 53) + 1,
            9_007_199_254_740_993,
            u64::MAX - 1,
            u64::MAX,
        ] {
            let field = SeedText::new(seed);
            assert_eq!(field.text, seed.to_string());
            assert_eq!(parse_seed(&field.text), Some(seed));
        }
        assert_eq!(parse_seed(" 1_000 "), Some(1000));
        for bad in ["", "-1", "1.5", "1e3", "18446744073709551616", "seed", "+3"] {
            assert_eq!(parse_seed(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn the_field_follows_what_is_typed_and_the_seed_set_elsewhere() {
        let mut field = SeedText::new(3);
        // Typed: the seed follows each text that reads as one, exactly.
        field.text = "18446744073709551615".into();
        assert_eq!(field.edited(), Some(u64::MAX));
        // Cleared while typing: the seed stays, the text too, until the field is left.
        field.text.clear();
        assert_eq!(field.edited(), None);
        field.sync(u64::MAX);
        assert_eq!(field.text, "");
        field.left();
        assert_eq!(field.text, "18446744073709551615");
        // "next seed" or a report's episode: the field shows the new seed.
        field.sync(9_007_199_254_740_993);
        assert_eq!(field.text, "9007199254740993");
    }
}
