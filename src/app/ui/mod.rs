//! The debugger's panels (egui), each a struct with `ui(&mut self, ui, session)` in its own
//! file: they share the [`Session`] and keep only what they alone draw from (text fields,
//! texture caches, a panel's own toggles). [`Debugger`] lays them out, one frame at a time;
//! long work goes through the session's jobs, so that no frame waits on it.

mod compare;
mod controls;
mod episodes;
mod history;
mod probe;
mod step;
mod timeline;
mod world;

use eframe::egui;
use egui::{Key, Vec2};

pub use super::numbers::step_line;

use super::Launch;
use super::screenshot::{ScreenshotTarget, Screenshots};
use super::session::Session;
use compare::ComparePanel;
use controls::ControlsPanel;
use episodes::EpisodesPanel;
use history::HistoryPanel;
use probe::ProbePanel;
use step::StepPanel;
use timeline::TimelinePanel;
use world::WorldPanel;

/// The debugger: the session and the panels that show it.
pub struct Debugger {
    session: Session,
    /// The top bar: checkpoint, level, seed, mission, exports, the report field.
    controls: ControlsPanel,
    /// The evaluation browsed, docked under the top bar.
    episodes: EpisodesPanel,
    /// The timeline, job progress and messages, at the bottom.
    timeline: TimelinePanel,
    /// The world, the agent's view and the overlay choice, on the left.
    world: WorldPanel,
    /// The probe, under the world.
    probe: ProbePanel,
    /// The compared checkpoint's world and policy, on the right in compare mode.
    compare: ComparePanel,
    /// The step: mission, maps, numbers, instruction tree and faithfulness, in the centre.
    step: StepPanel,
    /// The episode at a glance, at the centre column's foot.
    history: HistoryPanel,
    /// The PNG button's pictures and the headless screenshot.
    shots: Screenshots,
    /// The window size asked for, until it has been checked against the screen's.
    asked_window: Option<[f32; 2]>,
}

impl Debugger {
    /// A debugger that loads what `launch` names and starts its episode; with `screenshot`,
    /// it takes one picture once the episode is in and closes.
    pub fn new(launch: &Launch, screenshot: Option<ScreenshotTarget>) -> Self {
        let shots = Screenshots::new(screenshot);
        Self {
            session: Session::new(launch),
            controls: ControlsPanel::new(launch, shots.sender()),
            episodes: EpisodesPanel::default(),
            timeline: TimelinePanel,
            world: WorldPanel::default(),
            probe: ProbePanel::default(),
            compare: ComparePanel::default(),
            step: StepPanel::new(launch.faithfulness),
            history: HistoryPanel::default(),
            shots,
            asked_window: None,
        }
    }

    /// The session: what is loaded, shown and selected.
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// The session, to change.
    pub fn session_mut(&mut self) -> &mut Session {
        &mut self.session
    }

    /// How far the main episode has come ([`Session::episode_progress`]).
    pub fn episode_progress(&self) -> Option<(usize, bool)> {
        self.session.episode_progress()
    }

    /// Checks, once the screen's size is known, that a window of `size` (logical points) fits
    /// on it, and says so in the window and on stderr where it does not
    /// ([`super::window_warning`]).
    pub fn asked_window(&mut self, size: [f32; 2]) {
        self.asked_window = Some(size);
    }

    /// The level seed of the episode shown, once one is.
    pub fn shown_seed(&self) -> Option<u64> {
        self.session.shown.as_ref().map(|s| s.trace.seed)
    }

    /// Moves the cursor to step `k`, or to the last step there is.
    pub fn go_to_step(&mut self, k: usize) {
        self.session.go_to_step(k);
    }

    /// The last message of the window, if it is an error.
    pub fn last_error(&self) -> Option<&str> {
        self.session.last_error()
    }

    /// The picture the world panel shows now ([`Session::world_image`]).
    pub fn world_image(&self) -> Option<image::RgbImage> {
        self.session.world_image()
    }

    /// Opens the evaluation in `dir` in the episodes panel ([`Session::open_report`]).
    pub fn open_report(&mut self, dir: &std::path::Path) {
        self.session.open_report(dir);
    }

    /// The report's episodes listed now, in order ([`Session::report_rows`]).
    pub fn report_rows(&self) -> Vec<usize> {
        self.session.report_rows()
    }

    /// Opens the report's episode `i` ([`Session::open_report_episode`]).
    pub fn open_report_episode(&mut self, i: usize) {
        self.session.open_report_episode(i);
    }

    /// Opens the next (or previous) failure listed ([`Session::step_report_failure`]).
    pub fn step_report_failure(&mut self, forward: bool) {
        self.session.step_report_failure(forward);
    }

    /// Draws the whole UI for one frame.
    pub fn frame(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        self.session.poll_jobs();
        if self.session.busy() {
            ctx.request_repaint();
        }
        self.shots.receive(&ctx, &mut self.session);
        self.check_window(&ctx);
        self.keyboard(&ctx);
        let len = self.session.len();
        let dt = ctx.input(|i| i.stable_dt).min(0.1);
        self.session.cursor.tick(dt, len);
        if self.session.cursor.playing {
            ctx.request_repaint();
        }
        egui::Panel::top("controls").show(ui, |ui| self.controls.ui(ui, &mut self.session));
        // Docked under the top bar: the list never lies over the step it opens.
        if self.session.report.is_some() {
            egui::Panel::top("episodes").show(ui, |ui| self.episodes.ui(ui, &mut self.session));
        }
        egui::Panel::bottom("timeline").show(ui, |ui| self.timeline.ui(ui, &mut self.session));
        let side = self.world_side(ui.available_size());
        egui::Panel::left("world")
            .exact_size(side + 16.0)
            .show(ui, |ui| {
                self.world.side = side;
                self.world.height = ui.available_height();
                egui::ScrollArea::vertical().show(ui, |ui| {
                    self.world.ui(ui, &mut self.session);
                    ui.separator();
                    self.probe.ui(ui, &mut self.session);
                });
            });
        if self.session.compare && self.session.compared.is_some() {
            egui::Panel::right("compare")
                .default_size(300.0)
                .show(ui, |ui| self.compare.ui(ui, &mut self.session));
        }
        egui::CentralPanel::default().show(ui, |ui| {
            // The episode plot has the column's foot to itself, so that a long mission's rows
            // of numbers and maps scroll above it instead of pushing it out of the window.
            let plotted = self
                .session
                .shown
                .as_ref()
                .is_some_and(|s| !s.trace.steps.is_empty());
            if plotted {
                self.history.height = (ui.available_height() * 0.12).clamp(90.0, 200.0);
                egui::Panel::bottom("episode plot")
                    .resizable(false)
                    .show(ui, |ui| self.history.ui(ui, &mut self.session));
            }
            egui::ScrollArea::vertical().show(ui, |ui| self.step.ui(ui, &mut self.session));
        });
        self.shots.maybe_take(&ctx, &self.session);
    }

    /// Side of the world picture: about 30 points a cell, so that a 16×16 or 22×22 room
    /// stays readable, within what the window leaves for the other panels.
    fn world_side(&self, window: Vec2) -> f32 {
        let cells = self
            .session
            .shown
            .as_ref()
            .and_then(|s| s.trace.steps.first())
            .map_or(8, |s| s.world.grid.width().max(s.world.grid.height()));
        let most = (window.y - 240.0).min(window.x * 0.42).max(300.0);
        (cells as f32 * 30.0).clamp(300.0, most)
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
            self.session.info(w);
        }
    }

    /// The keys: ← / → step, space play / pause, Home / End; with a report open, N / P the
    /// next / previous failure listed. None while a field has the keyboard.
    fn keyboard(&mut self, ctx: &egui::Context) {
        let typing = ctx.memory(|m| m.focused().is_some());
        if typing {
            return;
        }
        let len = self.session.len();
        let cursor = &mut self.session.cursor;
        ctx.input(|i| {
            if i.key_pressed(Key::ArrowRight) {
                cursor.nudge(1, len);
            }
            if i.key_pressed(Key::ArrowLeft) {
                cursor.nudge(-1, len);
            }
            if i.key_pressed(Key::Space) {
                cursor.playing = !cursor.playing;
            }
            if i.key_pressed(Key::Home) {
                cursor.step = 0;
            }
            if i.key_pressed(Key::End) {
                cursor.step = len.saturating_sub(1);
            }
        });
        let (next, previous) = ctx.input(|i| (i.key_pressed(Key::N), i.key_pressed(Key::P)));
        if self.session.report.is_some() && (next || previous) {
            self.session.step_report_failure(next);
        }
    }
}
