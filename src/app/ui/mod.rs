//! The debugger's panels (egui). All state lives in [`Debugger`]; long work goes through
//! [`super::session`] jobs so that no frame waits on it.
//!
//! The struct and the frame layout are here; each panel and concern is drawn by its own
//! `impl Debugger` block in a child module, so that they all reach the private state.

mod controls;
mod episodes;
mod history;
mod jobs;
mod numbers;
mod probe;
mod screenshot;
mod tree;
mod world;

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};

use eframe::egui;
use egui::{ColorImage, TextureHandle, Vec2};

pub use numbers::step_line;

use super::session::{Agent, Cursor, Job, Shown, start_attention_probe};
use crate::env::Pos;
use crate::env::level::LevelConfig;
use crate::env::object::{Color, ObjectKind};

/// Options the debugger starts with (from the command line).
#[derive(Clone, Debug)]
pub struct StartOptions {
    /// Main checkpoint spec.
    pub checkpoint: String,
    /// Second checkpoint for compare mode.
    pub compare: Option<String>,
    /// Level; `None` = the checkpoint's.
    pub level: Option<LevelConfig>,
    /// Seed.
    pub seed: u64,
    /// Sampled actions.
    pub sample: bool,
    /// Step to show first.
    pub step: usize,
    /// Mission override.
    pub mission: Option<String>,
    /// Open with the faithfulness view shown.
    pub faithfulness: bool,
    /// An evaluation to browse in the episodes panel (`view --report DIR`).
    pub report: Option<crate::metrics::report::browse::Browser>,
}

/// Where a headless screenshot goes and where its outcome is reported.
pub type ScreenshotTarget = (PathBuf, Arc<Mutex<Option<Result<(), String>>>>);

/// Which map is laid over the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Overlay {
    None,
    Combined,
    Word,
}

/// The debugger.
#[expect(
    clippy::struct_excessive_bools,
    reason = "independent UI toggles and flags of one window"
)]
pub struct Debugger {
    agent: Option<Agent>,
    compare_agent: Option<Agent>,
    checkpoint_text: String,
    compare_text: String,
    compare: bool,
    level: LevelConfig,
    seed: u64,
    sample: bool,
    mission_text: String,
    shown: Option<Shown>,
    /// Whether `shown` is an episode whose steps are still coming.
    streaming: bool,
    compared: Option<Shown>,
    cursor: Cursor,
    selected_word: usize,
    overlay: Overlay,
    selected_cell: Option<Pos>,
    /// An object picked up with "move object…": the next click on the world moves it there.
    moving_from: Option<Pos>,
    edit_color: Color,
    edit_kind: ObjectKind,
    jobs: Vec<Job>,
    cancel: Arc<AtomicBool>,
    messages: Vec<(bool, String)>,
    export_dir: String,
    connect_url: String,
    textures: HashMap<(u64, usize, u8), TextureHandle>,
    generation: u64,
    alpha: f64,
    pending_step: Option<usize>,
    /// Headless screenshot: path, and where the outcome goes.
    screenshot: Option<ScreenshotTarget>,
    frames_ready: u32,
    shot_tx: Sender<(Arc<ColorImage>, PathBuf, bool)>,
    shot_rx: Receiver<(Arc<ColorImage>, PathBuf, bool)>,
    /// A screenshot has been requested and not yet received.
    shot_pending: bool,
    /// Show the faithfulness view (occlusion, interventions, probes).
    show_faithfulness: bool,
    /// Whether the maps of words with no role (function words: "go", "the", "then") fold into
    /// one line; `None` folds them on missions longer than BabyAI's local ones (9 words).
    fold_function_words: Option<bool>,
    faithfulness: super::faithful::FaithfulnessView,
    /// The evaluation browsed in the episodes panel.
    report: Option<crate::metrics::report::browse::Browser>,
    /// The top bar's field naming an evaluation's folder.
    report_text: String,
    /// Whether the episodes panel is open.
    show_episodes: bool,
    /// Whether the panel brings the selected row into view at its next frame.
    report_scroll: bool,
    /// The window size asked for, until it has been checked against the screen's.
    asked_window: Option<[f32; 2]>,
}

impl Debugger {
    /// A debugger that loads `opts` and starts the first episode.
    pub fn new(opts: &StartOptions, screenshot: Option<ScreenshotTarget>) -> Self {
        let (shot_tx, shot_rx) = channel();
        let mut messages = Vec::new();
        let agent = Agent::load(&opts.checkpoint)
            .map_err(|e| messages.push((true, e)))
            .ok();
        let compare_agent = opts.compare.as_deref().and_then(|c| {
            Agent::load(c)
                .map_err(|e| messages.push((true, format!("compare: {e}"))))
                .ok()
        });
        let level = opts
            .level
            .or_else(|| agent.as_ref().map(Agent::level))
            .unwrap_or_default();
        let mut me = Self {
            checkpoint_text: opts.checkpoint.clone(),
            compare_text: opts
                .compare
                .clone()
                .unwrap_or_else(|| "bundled:baseline".into()),
            compare: compare_agent.is_some(),
            agent,
            compare_agent,
            level,
            seed: opts.seed,
            sample: opts.sample,
            mission_text: opts.mission.clone().unwrap_or_default(),
            shown: None,
            streaming: false,
            compared: None,
            cursor: Cursor::default(),
            selected_word: 0,
            overlay: Overlay::Combined,
            selected_cell: None,
            moving_from: None,
            edit_color: Color::Red,
            edit_kind: ObjectKind::Ball,
            jobs: Vec::new(),
            cancel: Arc::new(AtomicBool::new(false)),
            messages,
            export_dir: ".".into(),
            connect_url: "rerun+http://127.0.0.1:9876/proxy".into(),
            textures: HashMap::new(),
            generation: 0,
            alpha: 0.5,
            pending_step: Some(opts.step),
            screenshot,
            frames_ready: 0,
            shot_tx,
            shot_rx,
            shot_pending: false,
            show_faithfulness: opts.faithfulness,
            fold_function_words: None,
            faithfulness: super::faithful::FaithfulnessView::default(),
            show_episodes: opts.report.is_some(),
            report_scroll: opts.report.is_some(),
            asked_window: None,
            report_text: opts
                .report
                .as_ref()
                .map_or_else(String::new, |b| b.dir.display().to_string()),
            report: opts.report.clone(),
        };
        me.run_episode(opts.mission.clone());
        me
    }

    /// How far the main episode has come: its steps so far and whether it is complete;
    /// `None` before its first step is there.
    pub fn episode_progress(&self) -> Option<(usize, bool)> {
        let shown = self.shown.as_ref()?;
        Some((shown.len(), shown.is_complete() && !self.streaming))
    }

    /// Checks, once the screen's size is known, that a window of `size` (logical points) fits
    /// on it, and says so in the window and on stderr where it does not
    /// ([`super::window_warning`]).
    pub fn asked_window(&mut self, size: [f32; 2]) {
        self.asked_window = Some(size);
    }

    /// The check of [`Self::asked_window`], at a frame where the monitor's size is known.
    fn check_window(&mut self, ctx: &egui::Context) {
        let Some(asked) = self.asked_window else {
            return;
        };
        let Some(monitor) = ctx.input(|i| i.viewport().monitor_size) else {
            return;
        };
        self.asked_window = None;
        if let Some(w) = super::window_warning(asked, monitor) {
            eprintln!("groundscope: {w}");
            self.info(w);
        }
    }

    /// The level seed of the episode shown, once one is.
    pub fn shown_seed(&self) -> Option<u64> {
        self.shown.as_ref().map(|s| s.trace.seed)
    }

    /// Moves the cursor to step `k`, or to the last step there is.
    pub fn go_to_step(&mut self, k: usize) {
        let len = self.shown.as_ref().map_or(0, Shown::len);
        self.cursor.step = k.min(len.saturating_sub(1));
    }

    /// The last message of the window, if it is an error.
    pub fn last_error(&self) -> Option<&str> {
        self.messages
            .last()
            .and_then(|(err, m)| err.then_some(m.as_str()))
    }

    fn info(&mut self, m: impl Into<String>) {
        self.messages.push((false, m.into()));
    }

    fn error(&mut self, m: impl Into<String>) {
        self.messages.push((true, m.into()));
    }

    fn busy(&self) -> bool {
        !self.jobs.is_empty()
    }

    /// Draws the whole UI for one frame.
    pub fn frame(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        self.poll_jobs(&ctx);
        self.check_window(&ctx);
        self.keyboard(&ctx);
        let len = self.shown.as_ref().map_or(0, Shown::len);
        let dt = ctx.input(|i| i.stable_dt).min(0.1);
        self.cursor.tick(dt, len);
        if self.cursor.playing {
            ctx.request_repaint();
        }
        egui::Panel::top("controls").show(ui, |ui| self.controls(ui));
        egui::Panel::bottom("timeline").show(ui, |ui| self.timeline(ui));
        let side = self.world_side(ui.available_size());
        egui::Panel::left("world")
            .exact_size(side + 16.0)
            .show(ui, |ui| {
                let height = ui.available_height();
                egui::ScrollArea::vertical().show(ui, |ui| self.left_column(ui, side, height));
            });
        if self.compare && self.compared.is_some() {
            egui::Panel::right("compare")
                .default_size(300.0)
                .show(ui, |ui| {
                    let c = self.compared.clone();
                    if let Some(c) = c {
                        ui.label(
                            egui::RichText::new(format!(
                                "compare: {}",
                                c.trace.model_name.as_ref().unwrap_or(&c.trace.checkpoint)
                            ))
                            .strong(),
                        );
                        let side = ui.available_width().min(300.0);
                        self.world_panel(ui, true, side);
                        let i = self.cursor.step.min(c.len().saturating_sub(1));
                        if let Some(step) = c.trace.steps.get(i) {
                            Self::policy_panel(ui, step, &c);
                        }
                    }
                });
        }
        egui::CentralPanel::default().show(ui, |ui| {
            // The episode plot has the column's foot to itself, so that a long mission's rows
            // of numbers and maps scroll above it instead of pushing it out of the window.
            if let Some(shown) = self.shown.clone()
                && !shown.trace.steps.is_empty()
            {
                let height = (ui.available_height() * 0.12).clamp(90.0, 200.0);
                egui::Panel::bottom("episode plot")
                    .resizable(false)
                    .show(ui, |ui| self.history_ui(ui, &shown, height));
            }
            egui::ScrollArea::vertical().show(ui, |ui| self.centre_column(ui));
        });
        self.episodes_window(&ctx);
        self.maybe_screenshot(&ctx);
    }

    /// Side of the world picture: about 30 points a cell, so that a 16×16 or 22×22 room
    /// stays readable, within what the window leaves for the other panels.
    fn world_side(&self, window: Vec2) -> f32 {
        let cells = self
            .shown
            .as_ref()
            .and_then(|s| s.trace.steps.first())
            .map_or(8, |s| s.world.grid.width().max(s.world.grid.height()));
        let most = (window.y - 240.0).min(window.x * 0.42).max(300.0);
        (cells as f32 * 30.0).clamp(300.0, most)
    }

    /// The overlay choice, the world, the agent's view and the probe; the view shrinks (to
    /// 96 points at least) to fit under the world in the column's `height`.
    fn left_column(&mut self, ui: &mut egui::Ui, side: f32, height: f32) {
        let ctx = ui.ctx().clone();
        let top = ui.cursor().min.y;
        // A model without maps (or the bot) has no M and no word to overlay.
        // (Judged from the episode shown; while none is, everything stays offered.)
        let has_maps = self.shown.as_ref().is_none_or(|s| {
            s.trace
                .steps
                .first()
                .is_none_or(|st| st.attention.is_some())
        });
        if !has_maps {
            self.overlay = Overlay::None;
        }
        ui.horizontal(|ui| {
            ui.label("overlay");
            ui.radio_value(&mut self.overlay, Overlay::None, "none");
            for (o, name) in [(Overlay::Combined, "M"), (Overlay::Word, "selected word")] {
                let r = ui.add_enabled(has_maps, egui::RadioButton::new(self.overlay == o, name));
                if r.clicked() {
                    self.overlay = o;
                }
                r.on_disabled_hover_text("this model has no attention maps");
            }
        });
        self.world_panel(ui, false, side);
        ui.label(
            egui::RichText::new(
                "magenta corners: targets waited on · numbers: clauses · dots: cells visited · floor tint and rings: the map",
            )
            .weak(),
        );
        ui.add_space(6.0);
        ui.label("agent view (agent-up; hatched: not seen)");
        let left = height - (ui.cursor().min.y - top) - 10.0;
        let view_side = left.min(side * 0.6).clamp(96.0, 200.0);
        if let Some(t) = self.texture(&ctx, self.cursor.step, 1, false) {
            ui.add(egui::Image::new(&t).fit_to_exact_size(Vec2::splat(view_side)));
        }
        ui.separator();
        self.edit_panel(ui);
    }

    /// The mission and the step, then the maps (with Δ beside `M` when the faithfulness view
    /// is on) so that they keep the space at every window size, then the step's numbers side
    /// by side, the instruction tree and the faithfulness summary with its probes.
    fn centre_column(&mut self, ui: &mut egui::Ui) {
        let Some(shown) = self.shown.clone() else {
            ui.label(if self.busy() {
                "running the episode…"
            } else {
                "no episode"
            });
            return;
        };
        let i = self.cursor.step.min(shown.len().saturating_sub(1));
        let (Some(step), Some(scene)) = (shown.trace.steps.get(i), shown.scene(i)) else {
            return;
        };
        let scene = &*scene;
        Self::policy_header(ui, step, &shown);
        // The maps come first, under the mission: the tree, the doors and the numbers give
        // way to them, below, at any window size (the column scrolls).
        // The maps shown: the words' (less those folded), M's and Δ's; and the clause numbers
        // of a sequence between them.
        let roles = crate::env::roles::roles_of(&step.world);
        let words = step.attention.as_ref().map_or(0, |a| a.words.len());
        let with_roles = roles.len() == words && words > 0;
        let shown_words = if with_roles && self.folds(words) {
            roles
                .iter()
                .filter(|r| r.class != crate::env::roles::WordClass::Other)
                .count()
        } else {
            words
        };
        // The accuracy lines go under the shorter column.
        let under_actions = shown_words > crate::record::scene::action_names().len();
        let numbers = |d: &mut Self, ui: &mut egui::Ui| {
            ui.horizontal_top(|ui| {
                ui.vertical(|ui| {
                    ui.set_width(330.0);
                    ui.label("action probabilities");
                    Self::policy_bars(ui, step);
                    if under_actions {
                        ui.add_space(4.0);
                        Self::accuracy_lines(ui, step, scene);
                    }
                });
                ui.vertical(|ui| {
                    d.weights_panel(ui, step);
                    if !under_actions {
                        ui.add_space(4.0);
                        Self::accuracy_lines(ui, step, scene);
                    }
                });
            });
        };
        // The bot has neither maps nor a network to probe: its plan (above) is what it
        // attends to.
        let is_bot = self
            .agent
            .as_ref()
            .is_some_and(|a| a.policy.acting().reads_world());
        if is_bot {
            ui.label(
                "minigrid's bot acts from the world itself: no attention maps and no network to probe; its plan is shown above",
            );
            ui.separator();
            numbers(self, ui);
            Self::tree_panel(ui, &scene.tree);
            return;
        }
        // A model without maps gets its occlusion saliency in their place, always.
        let mapless = step.attention.is_none();
        let faithful = self.show_faithfulness || mapless;
        let agent = self.agent.clone().filter(|_| faithful);
        if let Some(agent) = &agent {
            self.faithfulness.update(agent, &shown, i, self.generation);
        }
        let clauses = if with_roles {
            roles
                .iter()
                .filter_map(|r| r.clause)
                .max()
                .map_or(0, |m| m + 1)
        } else {
            0
        };
        let n_maps = shown_words + usize::from(words > 0) + usize::from(faithful);
        // Maps wrap into rows of at most this many: a long mission's maps stay on screen.
        let side = numbers::map_side(
            ui,
            n_maps.min(numbers::MAPS_PER_ROW),
            if clauses > 1 { clauses } else { 0 },
        );
        if mapless {
            ui.label(
                "no attention maps: the occlusion saliency below (how much the action distribution changes when a cell becomes floor) stands in for them",
            );
            ui.horizontal_top(|ui| {
                self.faithfulness
                    .occlusion_ui(ui, side, Some(&step.obs), true);
            });
        } else {
            // The boxes that change the maps come first: with a long mission unfolded into
            // two rows of maps they stay in the window.
            ui.horizontal(|ui| {
                ui.checkbox(
                    &mut self.show_faithfulness,
                    "faithfulness: does this step's behaviour depend on M?",
                );
                let words = step.attention.as_ref().map_or(0, |a| a.words.len());
                let mut fold = self.folds(words);
                if ui
                    .checkbox(&mut fold, "fold function words")
                    .on_hover_text("the maps of words with no role in the grammar (go, to, the, then, …) as one line")
                    .changed()
                {
                    self.fold_function_words = Some(fold);
                }
            });
            // The row borrows the debugger mutably (a click selects a map), so Δ's view is
            // taken out for the while.
            let taken = std::mem::take(&mut self.faithfulness);
            self.maps_row(ui, step, scene, side, |ui| {
                if faithful {
                    taken.occlusion_ui(ui, side, Some(&step.obs), false);
                }
            });
            self.faithfulness = taken;
        }
        ui.separator();
        numbers(self, ui);
        Self::tree_panel(ui, &scene.tree);
        if let Some(agent) = agent {
            let combined = step.attention.as_ref().map(|a| &a.combined);
            let asked = self.faithfulness.summary_ui(ui, &agent, &shown, combined);
            if let Some(how) = asked {
                self.jobs
                    .push(start_attention_probe(&agent, &shown, how, self.alpha));
            }
        }
    }
}
