//! The interactive debugger (eframe/egui): step through an episode, see every word's map, the
//! combined map and the policy's numbers on one step cursor, probe the agent by editing the
//! world or the mission, compare two checkpoints, browse an evaluation's episodes, and export.
//!
//! In egui's `View` shape: a [`session::Session`] holds the state — the agents, the one
//! episode asked for ([`EpisodeRequest`]), the cursor, the selection, the evaluation browsed
//! and the background jobs — and each panel of [`ui`] is a struct whose
//! `ui(&mut self, ui, session)` draws it and changes the session. [`episodes`] is the
//! episodes panel's model; the other modules hold what the panels draw with (pictures, maps,
//! numbers, the instruction tree, the seed field, screenshots).

pub mod episodes;
pub mod faithful;
pub mod gif;
mod maps;
mod numbers;
mod pictures;
mod screenshot;
mod seed;
pub mod session;
pub mod shown;
mod tree;
pub mod ui;

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use eframe::egui;
use thiserror::Error;

use crate::metrics::MetricsError;

pub use crate::episode::EpisodeRequest;
pub use screenshot::ScreenshotTarget;
pub use ui::Debugger;

/// What the debugger opens with (`view`'s flags): the episode, a checkpoint to run beside it,
/// whether the faithfulness view shows, and an evaluation to browse.
#[derive(Clone, Debug)]
pub struct Launch {
    /// The episode to open: its checkpoint, level, seed, mode, step and mission.
    pub request: EpisodeRequest,
    /// A second checkpoint for compare mode.
    pub compare: Option<String>,
    /// Open with the faithfulness view shown.
    pub faithfulness: bool,
    /// An evaluation to browse in the episodes panel (`view --report DIR`).
    pub report: Option<episodes::Browser>,
}

impl Launch {
    /// The debugger on `request` alone: no compare mode, no faithfulness view, no report.
    pub fn new(request: EpisodeRequest) -> Self {
        Self {
            request,
            compare: None,
            faithfulness: false,
            report: None,
        }
    }

    /// The debugger on an evaluation (`view --report DIR`), opened at its first failure, else
    /// its first episode, selected: a checkpoint's episode run by its checkpoint, a Python
    /// policy's replayed read-only from the report — with nothing to load, so the checkpoint
    /// field is left empty rather than given the policy's name (one named `bot` is not
    /// minigrid's bot). Fails on a report without episodes, and on a Python policy's episode
    /// whose actions the report does not hold.
    pub fn from_report(mut report: episodes::Browser) -> Result<Self, MetricsError> {
        let first = report.first().ok_or_else(|| {
            MetricsError::Invalid(format!(
                "{}: episodes.csv lists no episode",
                report.report.dir.display()
            ))
        })?;
        let request = if report.is_python(first) {
            let rec = report.recorded(first)?;
            EpisodeRequest {
                mode: rec.mode,
                step: rec.step,
                ..EpisodeRequest::new(String::new(), rec.level, rec.seed)
            }
        } else {
            report.episode(first)?
        };
        report.selected = Some(first);
        Ok(Self {
            report: Some(report),
            ..Self::new(request)
        })
    }
}

/// Why the debugger could not run.
#[derive(Debug, Error)]
pub enum AppError {
    /// No display to open a window on.
    #[error(
        "no display ({0}); the debugger needs a desktop session or X server. Without one, record \
         the episode instead: `groundscope replay --seed N --save episode.rrd` and open it with \
         `rerun episode.rrd`, or take a screenshot under Xvfb: `xvfb-run -a groundscope view --screenshot out.png`"
    )]
    NoDisplay(String),
    /// The window or its renderer failed.
    #[error("the debugger window failed: {0}")]
    Window(String),
    /// The headless screenshot failed.
    #[error("screenshot: {0}")]
    Screenshot(String),
}

/// How to open the window.
#[derive(Clone, Debug)]
pub struct WindowOptions {
    /// Inner size in logical pixels.
    pub size: [f32; 2],
    /// Render one frame to this PNG and exit.
    pub screenshot: Option<PathBuf>,
}

/// Whether a display seems available (X11 or Wayland).
pub fn display_available() -> Result<(), AppError> {
    let set = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
    if set("DISPLAY") || set("WAYLAND_DISPLAY") {
        Ok(())
    } else {
        Err(AppError::NoDisplay(
            "neither DISPLAY nor WAYLAND_DISPLAY is set".into(),
        ))
    }
}

/// Opens the debugger and blocks until its window closes (or, with a screenshot path, until
/// the picture is written).
pub fn run(launch: &Launch, window: &WindowOptions) -> Result<(), AppError> {
    display_available()?;
    let outcome: Arc<Mutex<Option<Result<(), String>>>> = Arc::new(Mutex::new(None));
    let shot = window.screenshot.clone().map(|p| (p, outcome.clone()));
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("groundscope")
            .with_inner_size(window.size),
        renderer: eframe::Renderer::Glow,
        ..eframe::NativeOptions::default()
    };
    let launch = launch.clone();
    let size = window.size;
    let result = eframe::run_native(
        "groundscope",
        native,
        Box::new(move |_cc| {
            let mut debugger = Debugger::new(&launch, shot);
            debugger.asked_window(size);
            Ok(Box::new(App(debugger)))
        }),
    );
    if let Err(e) = result {
        let msg = e.to_string();
        return Err(
            if msg.to_lowercase().contains("display") || msg.contains("XOpenDisplay") {
                AppError::NoDisplay(msg)
            } else {
                AppError::Window(msg)
            },
        );
    }
    if window.screenshot.is_some() {
        let got = outcome.lock().ok().and_then(|mut o| o.take());
        return match got {
            Some(Ok(())) => Ok(()),
            Some(Err(e)) => Err(AppError::Screenshot(e)),
            None => Err(AppError::Screenshot(
                "the window closed before the picture was taken".into(),
            )),
        };
    }
    Ok(())
}

/// What to say when the window asked for (`--window W×H`, logical points) is larger than the
/// screen it opens on (`monitor`, logical points): the window manager shrinks or clips it, so
/// the layout the size was chosen for is not what shows. `None` when it fits.
pub fn window_warning(asked: [f32; 2], monitor: egui::Vec2) -> Option<String> {
    (asked[0] > monitor.x || asked[1] > monitor.y).then(|| {
        format!(
            "--window {}x{} is larger than the screen ({}x{}): the window manager shrinks or clips it; pass --window {}x{} or smaller",
            asked[0].round(),
            asked[1].round(),
            monitor.x.round(),
            monitor.y.round(),
            asked[0].min(monitor.x).round(),
            asked[1].min(monitor.y).round()
        )
    })
}

struct App(Debugger);

impl eframe::App for App {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.0.frame(ui);
    }
}
