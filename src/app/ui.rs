//! The debugger's panels (egui). All state lives in [`Debugger`]; long work goes through
//! [`super::session`] jobs so that no frame waits on it.

use std::collections::HashMap;
use std::fmt::Write as _;

use eframe::egui;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};

use egui::{
    Color32, ColorImage, Key, Pos2, Rect, Sense, Stroke, StrokeKind, TextureHandle, TextureOptions,
    Vec2,
};

use super::session::{
    Agent, Cursor, Export, Job, JobResult, Request, Shown, failure_step, next_miss,
    start_attention_probe, start_episodes, start_export, start_probe,
};
use crate::env::edit::Edit;
use crate::env::level::{LevelConfig, TaskSet};
use crate::env::object::{Color, ObjectKind};
use crate::env::view::{VIEW_SIZE, view_from_world};
use crate::env::vocab;
use crate::env::{Pos, world_from_view};
use crate::episode::{ActionMode, StepRecord};
use crate::metrics::grounding::ObjectHit;
use crate::policy::ViewMap;
use crate::record::StepScene;
use crate::record::scene::action_names;
use crate::render::colorize;

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

fn rgb_texture(ctx: &egui::Context, name: &str, img: &image::RgbImage) -> TextureHandle {
    let (w, h) = img.dimensions();
    ctx.load_texture(
        name,
        ColorImage::from_rgb([w as usize, h as usize], img.as_raw()),
        TextureOptions::NEAREST,
    )
}

fn c32(rgb: [u8; 3]) -> Color32 {
    Color32::from_rgb(rgb[0], rgb[1], rgb[2])
}

fn hit_color(h: &ObjectHit) -> Color32 {
    c32(crate::record::scene::hit_color(h))
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
            .or_else(|| agent.as_ref().map(|a| a.ckpt.meta.level))
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

    fn run_episode(&mut self, mission: Option<String>) {
        let Some(agent) = self.agent.clone() else {
            self.error("no checkpoint loaded");
            return;
        };
        let req = Request {
            level: self.level,
            seed: self.seed,
            mode: if self.sample {
                ActionMode::Sampled
            } else {
                ActionMode::Greedy
            },
            mission,
        };
        let compare = if self.compare {
            self.compare_agent.clone()
        } else {
            None
        };
        self.jobs
            .push(start_episodes(agent, compare, req, self.alpha));
    }

    fn load_checkpoints(&mut self) {
        match Agent::load(self.checkpoint_text.trim()) {
            Ok(a) => {
                self.level = a.ckpt.meta.level;
                self.info(format!("loaded {}", a.spec));
                self.agent = Some(a);
            }
            Err(e) => self.error(e),
        }
        if self.compare {
            match Agent::load(self.compare_text.trim()) {
                Ok(a) => self.compare_agent = Some(a),
                Err(e) => {
                    self.error(format!("compare: {e}"));
                    self.compare_agent = None;
                }
            }
        }
        self.run_episode(None);
    }

    fn poll_jobs(&mut self, ctx: &egui::Context) {
        let mut finished = Vec::new();
        self.jobs.retain(|job| match job.poll() {
            Some(r) => {
                finished.push(r);
                false
            }
            None => true,
        });
        for r in finished {
            match r {
                JobResult::Episodes(pair) => {
                    let (a, b) = *pair;
                    self.generation += 1;
                    self.textures.clear();
                    let step = self.pending_step.take().unwrap_or(0);
                    self.cursor = Cursor {
                        step: step.min(a.len().saturating_sub(1)),
                        ..Cursor::default()
                    };
                    self.mission_text.clone_from(&a.trace.mission);
                    self.shown = Some(a);
                    self.compared = b;
                    self.selected_word = 0;
                }
                JobResult::Probed(s, k) => {
                    self.generation += 1;
                    self.textures.clear();
                    self.info(format!(
                        "re-ran from step {k}: {} in {} steps",
                        if s.trace.success() {
                            "success"
                        } else {
                            "failure"
                        },
                        s.len()
                    ));
                    self.mission_text = s
                        .trace
                        .steps
                        .get(k)
                        .map_or_else(|| s.trace.mission.clone(), |st| st.world.mission.clone());
                    self.cursor.step = k.min(s.len().saturating_sub(1));
                    self.shown = Some(*s);
                }
                JobResult::Exported(m) => self.info(m),
                JobResult::Failed(e) => self.error(e),
            }
        }
        if self.busy() {
            ctx.request_repaint();
        }
        if let Ok((img, path, close)) = self.shot_rx.try_recv() {
            self.shot_pending = false;
            let result = save_color_image(&img, &path);
            match &result {
                Ok(()) => self.info(format!("wrote {}", path.display())),
                Err(e) => self.error(e.clone()),
            }
            if close {
                if let Some((_, out)) = &self.screenshot
                    && let Ok(mut o) = out.lock()
                {
                    *o = Some(result);
                }
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
        }
    }

    fn request_shot(&mut self, ctx: &egui::Context, path: PathBuf, then_close: bool) {
        let tx = self.shot_tx.clone();
        ctx.request_screenshot(move |img| {
            let _ = tx.send((img, path, then_close));
        });
        self.shot_pending = true;
        ctx.request_repaint();
    }

    fn probe(&mut self, edit: &Edit) {
        let (Some(agent), Some(shown)) = (&self.agent, &self.shown) else {
            return;
        };
        match start_probe(agent, shown, self.cursor.step, edit, self.alpha) {
            Ok(job) => self.jobs.push(job),
            Err(e) => self.error(format!("edit refused: {e}")),
        }
    }

    fn export(&mut self, what: Export) {
        let Some(shown) = &self.shown else {
            return;
        };
        self.cancel = Arc::new(AtomicBool::new(false));
        let job = start_export(shown, what, self.alpha, self.cancel.clone());
        self.jobs.push(job);
    }

    fn export_path(&self, ext: &str) -> PathBuf {
        PathBuf::from(self.export_dir.trim()).join(format!(
            "groundscope-seed{}-step{}.{ext}",
            self.seed, self.cursor.step
        ))
    }

    fn texture(
        &mut self,
        ctx: &egui::Context,
        step: usize,
        kind: u8,
        compared: bool,
    ) -> Option<TextureHandle> {
        let shown = if compared {
            self.compared.as_ref()?
        } else {
            self.shown.as_ref()?
        };
        let key = (self.generation * 2 + u64::from(compared), step, kind);
        if let Some(t) = self.textures.get(&key) {
            return Some(t.clone());
        }
        let scene = shown.scenes.get(step)?;
        let img = if kind == 0 { &scene.world } else { &scene.view };
        let t = rgb_texture(ctx, &format!("{key:?}"), img);
        self.textures.insert(key, t.clone());
        Some(t)
    }

    fn keyboard(&mut self, ctx: &egui::Context) {
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
    }

    fn controls(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            ui.label("checkpoint");
            egui::ComboBox::from_id_salt("ckpt")
                .selected_text(self.checkpoint_text.clone())
                .show_ui(ui, |ui| {
                    for n in crate::policy::bundled::names() {
                        ui.selectable_value(&mut self.checkpoint_text, n.clone(), n);
                    }
                });
            ui.add(egui::TextEdit::singleline(&mut self.checkpoint_text).desired_width(160.0))
                .on_hover_text("bundled:attention, bundled:baseline, or a checkpoint NAME (NAME.json + NAME.safetensors)");
            ui.checkbox(&mut self.compare, "compare with");
            ui.add_enabled(
                self.compare,
                egui::TextEdit::singleline(&mut self.compare_text).desired_width(140.0),
            );
            if ui.button("load").clicked() {
                self.load_checkpoints();
            }
            ui.separator();
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
            ui.label("seed");
            ui.add(egui::DragValue::new(&mut self.seed));
            ui.checkbox(&mut self.sample, "sampled");
            if ui.button("run").on_hover_text("run a fresh episode").clicked() {
                if let Err(e) = self.level.validate() {
                    self.error(e.to_string());
                } else {
                    self.run_episode(None);
                }
            }
            if ui.button("next seed").clicked() {
                self.seed += 1;
                self.run_episode(None);
            }
        });
        ui.horizontal_wrapped(|ui| {
            ui.label("mission");
            let r = ui.add(egui::TextEdit::singleline(&mut self.mission_text).desired_width(260.0));
            let unknown: Vec<&str> = self
                .mission_text
                .split_whitespace()
                .filter(|w| vocab::token_id(&w.to_lowercase()).is_none())
                .collect();
            if !unknown.is_empty() {
                ui.colored_label(
                    Color32::from_rgb(230, 60, 60),
                    format!("not in the vocabulary: {}", unknown.join(", ")),
                )
                .on_hover_text(format!("known words: {}", vocab::VOCABULARY[1..].join(" ")));
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
            if ui.button("Rerun: spawn").clicked() {
                self.export(Export::Spawn);
            }
            ui.add(egui::TextEdit::singleline(&mut self.connect_url).desired_width(200.0));
            if ui.button("connect").clicked() {
                self.export(Export::Connect(self.connect_url.clone()));
            }
        });
    }

    fn timeline(&mut self, ui: &mut egui::Ui) {
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
            ui.add(egui::Slider::new(&mut s, 0..=len.saturating_sub(1)).text(format!("of {len}")));
            self.cursor.step = s;
            ui.add(egui::Slider::new(&mut self.cursor.speed, 0.5..=20.0).text("steps/s"));
            if let Some(shown) = &self.shown {
                if ui.button("next grounding miss").clicked() {
                    match next_miss(&shown.scenes, self.cursor.step) {
                        Some(i) => self.cursor.step = i,
                        None => self
                            .messages
                            .push((false, "no grounding miss in this episode".into())),
                    }
                }
                let fail = failure_step(&shown.trace);
                if ui
                    .add_enabled(fail.is_some(), egui::Button::new("failure"))
                    .clicked()
                    && let Some(i) = fail
                {
                    self.cursor.step = i;
                }
                // Why it failed: the class `eval` gives the same episode (README,
                // Evaluation).
                if let Some(d) = &shown.failure {
                    ui.label(
                        egui::RichText::new(format!("failed: {}", d.class.name()))
                            .color(Color32::from_rgb(230, 120, 90)),
                    )
                    .on_hover_text(format!(
                        "target in view at {} step(s); M on it at {}",
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

    /// The world picture with the chosen overlay and grounding marks; click selects a cell.
    fn world_panel(&mut self, ui: &mut egui::Ui, compared: bool, side: f32) {
        let step_i = self.cursor.step;
        let Some(shown) = (if compared {
            self.compared.clone()
        } else {
            self.shown.clone()
        }) else {
            ui.label("no episode");
            return;
        };
        let step_i = step_i.min(shown.len().saturating_sub(1));
        let (Some(step), Some(scene)) = (shown.trace.steps.get(step_i), shown.scenes.get(step_i))
        else {
            return;
        };
        let Some(tex) = self.texture(ui.ctx(), step_i, 0, compared) else {
            return;
        };
        let (gw, gh) = (step.world.grid.width(), step.world.grid.height());
        let cell = side / gw.max(gh) as f32;
        let size = Vec2::new(cell * gw as f32, cell * gh as f32);
        let (rect, resp) = ui.allocate_exact_size(size, Sense::click());
        let painter = ui.painter_at(rect);
        painter.image(
            tex.id(),
            rect,
            Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
            Color32::WHITE,
        );
        let map = step.attention.as_ref().and_then(|a| match self.overlay {
            Overlay::None => None,
            Overlay::Combined => Some(a.combined),
            Overlay::Word => a.words.get(self.selected_word).map(|w| w.map),
        });
        let cell_rect = |p: Pos| {
            Rect::from_min_size(
                rect.min + Vec2::new(p.0 as f32 * cell, p.1 as f32 * cell),
                Vec2::splat(cell),
            )
        };
        if let Some(map) = map {
            for (vy, row) in map.iter().enumerate() {
                for (vx, &value) in row.iter().enumerate() {
                    let p = world_from_view(step.world.agent_pos, step.world.agent_dir, (vx, vy));
                    if step.world.grid.contains(p) {
                        let c = colorize(value, 0.0, scene.scale_max);
                        painter.rect_filled(
                            cell_rect(p),
                            0.0,
                            Color32::from_rgba_unmultiplied(c[0], c[1], c[2], 150),
                        );
                    }
                }
            }
        }
        if let Some(sel) = self.selected_cell
            && !compared
        {
            painter.rect_stroke(
                cell_rect(sel),
                0.0,
                Stroke::new(2.0, Color32::from_rgb(0, 160, 255)),
                StrokeKind::Inside,
            );
        }
        if let Some(pos) = resp.hover_pos() {
            let p = (
                ((pos.x - rect.min.x) / cell) as i32,
                ((pos.y - rect.min.y) / cell) as i32,
            );
            let content = match step.world.grid.get(p) {
                Some(o) => o.describe(),
                None if p == step.world.agent_pos => "agent".into(),
                None => "empty".into(),
            };
            let value = view_from_world(step.world.agent_pos, step.world.agent_dir, p)
                .and_then(|v| map.map(|m| (v, m[v.1][v.0])));
            let text = match value {
                Some((v, x)) => format!("cell {p:?}: {content}\nview cell {v:?}, map value {x:.4}"),
                None => format!("cell {p:?}: {content}\n(outside the view)"),
            };
            let resp = resp.clone().on_hover_text_at_pointer(text);
            if resp.clicked() && !compared {
                if let Some(from) = self.moving_from.take() {
                    self.probe(&Edit::MoveObject(from, p));
                }
                self.selected_cell = Some(p);
            }
        }
    }

    /// A 7×7 heat map with grounding marks; returns the response (click selects).
    pub(super) fn heat_map(
        ui: &mut egui::Ui,
        map: &ViewMap,
        hi: f32,
        hits: &[ObjectHit],
        side: f32,
        selected: bool,
    ) -> egui::Response {
        let (rect, resp) = ui.allocate_exact_size(Vec2::splat(side), Sense::click());
        let painter = ui.painter_at(rect);
        let c = side / VIEW_SIZE as f32;
        for (vy, row) in map.iter().enumerate() {
            for (vx, &v) in row.iter().enumerate() {
                let r = Rect::from_min_size(
                    rect.min + Vec2::new(vx as f32 * c, vy as f32 * c),
                    Vec2::splat(c),
                );
                painter.rect_filled(r, 0.0, c32(colorize(v, 0.0, hi)));
            }
        }
        for h in hits {
            let centre =
                rect.min + Vec2::new((h.cell.0 as f32 + 0.5) * c, (h.cell.1 as f32 + 0.5) * c);
            painter.circle_stroke(centre, c * 0.35, Stroke::new(2.5, hit_color(h)));
        }
        // The agent, bottom middle, facing up.
        let a = rect.min + Vec2::new(3.5 * c, 6.5 * c);
        painter.add(egui::Shape::convex_polygon(
            vec![
                a + Vec2::new(0.0, -0.3 * c),
                a + Vec2::new(0.25 * c, 0.25 * c),
                a + Vec2::new(-0.25 * c, 0.25 * c),
            ],
            Color32::from_rgb(255, 80, 80),
            Stroke::NONE,
        ));
        if selected {
            painter.rect_stroke(
                rect,
                0.0,
                Stroke::new(3.0, Color32::from_rgb(0, 160, 255)),
                StrokeKind::Inside,
            );
        }
        if let Some(pos) = resp.hover_pos() {
            let (vx, vy) = (
                ((pos.x - rect.min.x) / c) as usize,
                ((pos.y - rect.min.y) / c) as usize,
            );
            if vx < VIEW_SIZE && vy < VIEW_SIZE {
                let mut text = format!("view cell ({vx}, {vy}): {:.5}", map[vy][vx]);
                for h in hits.iter().filter(|h| h.cell == (vx, vy)) {
                    let _ = write!(
                        text,
                        "\nrelated object: acc {} · ng {} · bs {} · cmb {}",
                        h.acc, h.acc_ng, h.acc_bs, h.acc_cmb
                    );
                }
                return resp.on_hover_text_at_pointer(text);
            }
        }
        resp
    }

    fn attention_panel(&mut self, ui: &mut egui::Ui, step: &StepRecord, scene: &StepScene) {
        let Some(att) = &step.attention else {
            ui.label("baseline model: no attention maps");
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

    fn policy_panel(ui: &mut egui::Ui, step: &StepRecord, shown: &Shown) {
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

    fn edit_panel(&mut self, ui: &mut egui::Ui) {
        ui.label(egui::RichText::new("probe").strong());
        let Some(sel) = self.selected_cell else {
            ui.label("click a world cell to edit it");
            if ui.button("turn agent left").clicked() {
                self.turn(3);
            }
            if ui.button("turn agent right").clicked() {
                self.turn(1);
            }
            return;
        };
        ui.label(format!("cell {sel:?}"));
        ui.horizontal_wrapped(|ui| {
            if ui.button("move agent here").clicked() {
                self.probe(&Edit::MoveAgent(sel));
            }
            if ui.button("turn left").clicked() {
                self.turn(3);
            }
            if ui.button("turn right").clicked() {
                self.turn(1);
            }
            if ui.button("remove object").clicked() {
                self.probe(&Edit::Remove(sel));
            }
            if ui
                .button("move object…")
                .on_hover_text("then click the cell to move it to")
                .clicked()
            {
                self.moving_from = Some(sel);
            }
        });
        if let Some(from) = self.moving_from {
            ui.label(format!("click the cell to move the object at {from:?} to"));
        }
        ui.horizontal_wrapped(|ui| {
            egui::ComboBox::from_id_salt("kind")
                .selected_text(self.edit_kind.name())
                .show_ui(ui, |ui| {
                    for k in [ObjectKind::Key, ObjectKind::Ball, ObjectKind::Box] {
                        ui.selectable_value(&mut self.edit_kind, k, k.name());
                    }
                });
            egui::ComboBox::from_id_salt("color")
                .selected_text(self.edit_color.name())
                .show_ui(ui, |ui| {
                    for c in Color::ALL {
                        ui.selectable_value(&mut self.edit_color, c, c.name());
                    }
                });
            if ui.button("add").clicked() {
                self.probe(&Edit::Add(sel, self.edit_kind, self.edit_color));
            }
            if ui.button("recolour").clicked() {
                self.probe(&Edit::Recolor(sel, self.edit_color));
            }
            if ui.button("clear selection").clicked() {
                self.selected_cell = None;
            }
        });
    }

    fn turn(&mut self, by: u8) {
        if let Some(s) = self
            .shown
            .as_ref()
            .and_then(|s| s.trace.steps.get(self.cursor.step))
        {
            let d = (s.world.agent_dir + by) % 4;
            self.probe(&Edit::TurnAgent(d));
        }
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
                            egui::RichText::new(format!("compare: {}", c.trace.checkpoint))
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
                ui.checkbox(
                    &mut self.show_faithfulness,
                    "faithfulness: does this step's behaviour depend on M?",
                );
                if self.show_faithfulness
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

    fn maybe_screenshot(&mut self, ctx: &egui::Context) {
        let Some((path, _)) = &self.screenshot else {
            return;
        };
        if self.shot_pending {
            return;
        }
        if self.busy() || self.shown.is_none() {
            // An episode that fails to load ends the screenshot with its error.
            if !self.busy()
                && let Some((true, e)) = self.messages.last()
                && let Some((_, out)) = &self.screenshot
                && let Ok(mut o) = out.lock()
            {
                *o = Some(Err(e.clone()));
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
            ctx.request_repaint();
            return;
        }
        // A few frames first, so that layout and textures have settled.
        self.frames_ready += 1;
        if self.frames_ready >= 3 {
            let p = path.clone();
            self.request_shot(ctx, p, true);
        } else {
            ctx.request_repaint();
        }
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

/// Saves an egui screenshot as PNG, atomically.
fn save_color_image(img: &ColorImage, path: &std::path::Path) -> Result<(), String> {
    let [w, h] = img.size;
    let rgb: Vec<u8> = img
        .pixels
        .iter()
        .flat_map(|c| [c.r(), c.g(), c.b()])
        .collect();
    let buf = image::RgbImage::from_raw(w as u32, h as u32, rgb)
        .ok_or_else(|| "screenshot has an inconsistent size".to_owned())?;
    crate::render::save_png(&buf, path).map_err(|e| e.to_string())
}
