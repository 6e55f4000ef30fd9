//! Screenshots: the PNG button's picture of the window, and the headless `--screenshot` run
//! that takes one picture, once the episode is in and the layout has settled, and closes the
//! window.

use std::path::PathBuf;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};

use eframe::egui;
use egui::ColorImage;

use super::session::Session;

/// Where a headless screenshot goes and where its outcome is reported.
pub type ScreenshotTarget = (PathBuf, Arc<Mutex<Option<Result<(), String>>>>);

/// A picture egui delivered, the file it goes to, and whether the window closes after it.
pub type Shot = (Arc<ColorImage>, PathBuf, bool);

/// Asks egui for a picture of the window, to be saved at `path` when it comes through `tx`
/// ([`Screenshots::receive`]); `then_close` closes the window after it.
pub fn request_shot(ctx: &egui::Context, tx: &Sender<Shot>, path: PathBuf, then_close: bool) {
    let tx = tx.clone();
    ctx.request_screenshot(move |img| {
        let _ = tx.send((img, path, then_close));
    });
    ctx.request_repaint();
}

/// The pictures asked for and where they go.
pub struct Screenshots {
    /// Headless screenshot: path, and where the outcome goes.
    target: Option<ScreenshotTarget>,
    /// Frames drawn with the episode in, before the headless picture is taken.
    frames_ready: u32,
    tx: Sender<Shot>,
    rx: Receiver<Shot>,
    /// The headless picture has been asked for and not yet received.
    pending: bool,
}

impl Screenshots {
    /// Screenshots of a window; with `target`, one picture taken headless, then the window
    /// closes.
    pub fn new(target: Option<ScreenshotTarget>) -> Self {
        let (tx, rx) = channel();
        Self {
            target,
            frames_ready: 0,
            tx,
            rx,
            pending: false,
        }
    }

    /// Where pictures asked for with [`request_shot`] are to be sent.
    pub fn sender(&self) -> Sender<Shot> {
        self.tx.clone()
    }

    /// Saves a picture egui has delivered, saying so in the session's message bar; a headless
    /// run then reports it and closes the window.
    pub fn receive(&mut self, ctx: &egui::Context, session: &mut Session) {
        if let Ok((img, path, close)) = self.rx.try_recv() {
            self.pending = false;
            let result = save_color_image(&img, &path);
            match &result {
                Ok(()) => session.info(format!("wrote {}", path.display())),
                Err(e) => session.error(e.clone()),
            }
            if close {
                if let Some((_, out)) = &self.target
                    && let Ok(mut o) = out.lock()
                {
                    *o = Some(result);
                }
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
        }
    }

    /// The headless run: once the episode is in (or has failed to load, which ends the run
    /// with its error) and a few frames have settled the layout, asks for the picture.
    pub fn maybe_take(&mut self, ctx: &egui::Context, session: &Session) {
        let Some((path, _)) = &self.target else {
            return;
        };
        if self.pending {
            return;
        }
        if session.busy() || session.shown.is_none() {
            // An episode that fails to load ends the screenshot with its error.
            if !session.busy()
                && let Some((true, e)) = session.messages.last()
                && let Some((_, out)) = &self.target
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
            request_shot(ctx, &self.tx, p, true);
            self.pending = true;
        } else {
            ctx.request_repaint();
        }
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
