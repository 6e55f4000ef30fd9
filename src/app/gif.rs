//! An episode as an animated GIF: per step, the world with `M` overlaid beside the agent view.

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbaImage, imageops};

use crate::episode::EpisodeTrace;
use crate::record::PendingFile;
use crate::record::scene::{StepScene, TILE_PX, trail, world_with_overlay};

/// Milliseconds each step is shown.
const FRAME_MS: u32 = 250;

/// One frame: the world (with `M` for attention models, the targets and the agent's trail
/// up to step `k`) and the view, side by side.
pub fn frame(trace: &EpisodeTrace, k: usize, scene: &StepScene) -> RgbaImage {
    let Some(step) = trace.steps.get(k) else {
        return RgbaImage::new(0, 0);
    };
    let world = world_with_overlay(step, scene, &trail(trace, k));
    let view = &scene.view;
    let gap = TILE_PX / 2;
    let (w, h) = (
        world.width() + gap + view.width(),
        world.height().max(view.height()),
    );
    let mut out = RgbaImage::from_pixel(w, h, image::Rgba([30, 30, 30, 255]));
    imageops::replace(
        &mut out,
        &image::DynamicImage::ImageRgb8(world).to_rgba8(),
        0,
        0,
    );
    imageops::replace(
        &mut out,
        &image::DynamicImage::ImageRgb8(view.clone()).to_rgba8(),
        i64::from(w - TILE_PX * 7),
        0,
    );
    out
}

/// Writes the episode as a looping GIF, atomically; `done` counts frames for a progress bar
/// and `stop` aborts (no file is left).
pub fn write_gif(
    trace: &EpisodeTrace,
    path: &Path,
    alpha: f64,
    done: &AtomicUsize,
    stop: &AtomicBool,
) -> Result<(), String> {
    let pending = PendingFile::new(path).map_err(|e| e.to_string())?;
    let file = std::fs::File::create(pending.path())
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    let mut enc = GifEncoder::new_with_speed(std::io::BufWriter::new(file), 10);
    enc.set_repeat(Repeat::Infinite)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    // One scene at a time: an episode's scenes all at once weigh 0.4 MB a step on a big world.
    for (i, step) in trace.steps.iter().enumerate() {
        let scene = &StepScene::new(step, alpha);
        if stop.load(Ordering::Relaxed) {
            return Err("export cancelled".into());
        }
        enc.encode_frame(Frame::from_parts(
            frame(trace, i, scene),
            0,
            0,
            Delay::from_numer_denom_ms(FRAME_MS, 1),
        ))
        .map_err(|e| format!("{}: {e}", path.display()))?;
        done.store(i + 1, Ordering::Relaxed);
    }
    drop(enc);
    pending.commit().map_err(|e| e.to_string())
}
