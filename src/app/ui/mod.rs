//! The debugger's panels (egui). All state lives in [`Debugger`]; long work goes through
//! [`super::session`] jobs so that no frame waits on it.
//!
//! The struct and the frame layout are here; each panel and concern is drawn by its own
//! `impl Debugger` block in a child module, so that they all reach the private state.

mod controls;
mod jobs;
mod numbers;
mod probe;
mod screenshot;
mod world;

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};

use eframe::egui;
use egui::{ColorImage, TextureHandle, Vec2};

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
    faithfulness: super::faithful::FaithfulnessView,
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
            faithfulness: super::faithful::FaithfulnessView::default(),
        };
        me.run_episode(opts.mission.clone());
        me
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
        self.keyboard(&ctx);
        let len = self.shown.as_ref().map_or(0, Shown::len);
        let dt = ctx.input(|i| i.stable_dt).min(0.1);
        self.cursor.tick(dt, len);
        if self.cursor.playing {
            ctx.request_repaint();
        }
        egui::Panel::top("controls").show(ui, |ui| self.controls(ui));
        egui::Panel::bottom("timeline").show(ui, |ui| self.timeline(ui));
        egui::Panel::left("world")
            .default_size(340.0)
            .show(ui, |ui| {
                ui.horizontal(|ui| {
                    ui.label("overlay");
                    ui.radio_value(&mut self.overlay, Overlay::None, "none");
                    ui.radio_value(&mut self.overlay, Overlay::Combined, "M");
                    ui.radio_value(&mut self.overlay, Overlay::Word, "selected word");
                });
                let side = ui.available_width().min(420.0);
                self.world_panel(ui, false, side);
                ui.add_space(6.0);
                ui.label("agent view (agent-up)");
                if let Some(t) = self.texture(&ctx, self.cursor.step, 1, false) {
                    ui.add(egui::Image::new(&t).fit_to_exact_size(Vec2::splat(side * 0.6)));
                }
                ui.separator();
                self.edit_panel(ui);
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
            let Some(shown) = self.shown.clone() else {
                ui.label(if self.busy() {
                    "running the episode…"
                } else {
                    "no episode"
                });
                return;
            };
            let i = self.cursor.step.min(shown.len().saturating_sub(1));
            let (Some(step), Some(scene)) = (shown.trace.steps.get(i), shown.scenes.get(i)) else {
                return;
            };
            egui::ScrollArea::vertical().show(ui, |ui| {
                Self::policy_panel(ui, step, &shown);
                ui.separator();
                self.attention_panel(ui, step, scene);
                ui.separator();
                // A model without maps gets its occlusion saliency in their place, always.
                let mapless = step.attention.is_none();
                if !mapless {
                    ui.checkbox(
                        &mut self.show_faithfulness,
                        "faithfulness: does this step's behaviour depend on M?",
                    );
                }
                if (self.show_faithfulness || mapless)
                    && let Some(agent) = self.agent.clone()
                {
                    let side = (ui.available_width() / 4.0).clamp(90.0, 170.0);
                    let asked =
                        self.faithfulness
                            .show(ui, &agent, &shown, i, self.generation, side);
                    if let Some(how) = asked {
                        self.jobs
                            .push(start_attention_probe(&agent, &shown, how, self.alpha));
                    }
                }
            });
        });
        self.maybe_screenshot(&ctx);
    }
}
