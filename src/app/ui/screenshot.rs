//! Screenshots: the PNG button, and the headless `--screenshot` run that takes one picture
//! and closes the window.

use std::path::PathBuf;

use eframe::egui;
use egui::ColorImage;

use super::Debugger;

impl Debugger {
    pub(super) fn request_shot(&mut self, ctx: &egui::Context, path: PathBuf, then_close: bool) {
        let tx = self.shot_tx.clone();
        ctx.request_screenshot(move |img| {
            let _ = tx.send((img, path, then_close));
        });
        self.shot_pending = true;
        ctx.request_repaint();
    }

    /// Saves a screenshot egui has delivered; a headless run then reports it and closes.
    pub(super) fn receive_shot(&mut self, ctx: &egui::Context) {
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

    pub(super) fn maybe_screenshot(&mut self, ctx: &egui::Context) {
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
