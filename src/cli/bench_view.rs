//! `groundscope bench view`: the debugger opening an episode, headless (egui without a
//! window or renderer), each level in a process of its own so that each gets its own peak
//! memory. Per level: the time to the first frame that shows step 0, the time until the
//! whole episode is in, the mean time of a frame while walking over the episode's steps, and
//! the process's peak resident memory (`VmHWM` of `/proc/self/status`); then one line with
//! the levels side by side. `--walk-every-step` walks every step instead and says, as it
//! goes, what the process holds (issue #83: whether the window grows with the steps shown).

use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Args;
use eframe::egui;
use groundscope::app::Debugger;

use super::flags::EpisodeArgs;
use super::view::{ViewArgs, start_options, window_size};
use crate::ExitStatus;

/// The levels timed by default: the paper's, whose episodes end in a few steps, and
/// BossLevel, whose 22×22 world and 1,728-step limit the default agent often runs to.
const DEFAULT_LEVELS: &str = "paper,BabyAI-BossLevel-v0";

/// Frames while the episode runs come no faster than a 60 Hz display's.
const FRAME: Duration = Duration::from_millis(16);

/// Frames drawn over the episode's steps once it is in (evenly spaced steps).
const WALK_FRAMES: usize = 200;

/// Points of a walk over every step at which the process's memory and textures are read:
/// enough to tell growth with the steps shown from a step in the memory.
const WALK_SAMPLES: usize = 10;

/// `bench view`'s flags.
#[derive(Debug, Args)]
pub struct BenchViewArgs {
    /// Levels, comma-separated: `paper` (the paper's level) or BabyAI ids.
    #[arg(long, visible_alias = "level", value_name = "IDS", default_value = DEFAULT_LEVELS)]
    levels: String,
    /// Level seed.
    #[arg(long, default_value_t = 3, allow_negative_numbers = true)]
    seed: u64,
    /// Checkpoint [default: as `view` chooses: bundled:attention, or bundled:babyai on a
    /// level whose mission it cannot read].
    #[arg(long, value_name = "NAME")]
    checkpoint: Option<String>,
    /// Window size in logical pixels.
    #[arg(long, value_name = "WxH", default_value = "1400x900")]
    window: String,
    /// Walk every step of the episode, one frame each, instead of up to 200 evenly spaced
    /// ones, and report the resident memory (`VmRSS`), egui's live textures and the scenes
    /// kept at ten points of the walk: what the window holds as the steps shown grow.
    #[arg(long)]
    walk_every_step: bool,
    /// Time one level in this process (what each level's own process runs).
    #[arg(long, hide = true)]
    in_process: bool,
}

/// Runs the benchmark: one JSON line per level, then one with the levels side by side.
pub fn run(args: &BenchViewArgs) -> anyhow::Result<ExitStatus> {
    let levels: Vec<&str> = args.levels.split(',').map(str::trim).collect();
    if args.in_process {
        let [level] = levels.as_slice() else {
            anyhow::bail!("--in-process times one level, not {}", args.levels);
        };
        println!("{}", time_level(args, level)?);
        return Ok(ExitStatus::Success);
    }
    // Checked here so that a bad id is one line from this process, not from a child.
    for level in &levels {
        view_args(args, level)?;
    }
    let exe = std::env::current_exe().context("finding this program to time each level")?;
    let mut lines = Vec::new();
    for level in &levels {
        let mut cmd = std::process::Command::new(&exe);
        cmd.args(["bench", "view", "--in-process", "--levels", level])
            .args(["--seed", &args.seed.to_string(), "--window", &args.window]);
        if let Some(c) = &args.checkpoint {
            cmd.args(["--checkpoint", c]);
        }
        if args.walk_every_step {
            cmd.arg("--walk-every-step");
        }
        let out = cmd.output().context("running the level's own process")?;
        let stdout = String::from_utf8_lossy(&out.stdout);
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            anyhow::bail!(
                "{level}: {}",
                err.trim().trim_start_matches("groundscope: ")
            );
        }
        let line: serde_json::Value = serde_json::from_str(stdout.trim())
            .with_context(|| format!("{level}: unreadable timing {stdout:?}"))?;
        println!("{line}");
        lines.push(line);
    }
    let column =
        |key: &str| -> Vec<serde_json::Value> { lines.iter().map(|l| l[key].clone()).collect() };
    let summary = serde_json::json!({
        "bench": "view",
        "side_by_side": true,
        "levels": column("level"),
        "steps": column("steps"),
        "time_to_first_frame_s": column("time_to_first_frame_s"),
        "time_to_full_episode_s": column("time_to_full_episode_s"),
        "walk_frame_ms": column("walk_frame_ms"),
        "peak_rss_bytes": column("peak_rss_bytes"),
        "walk_rss_growth_bytes_per_step": column("walk_rss_growth_bytes_per_step"),
    });
    println!("{summary}");
    Ok(ExitStatus::Success)
}

/// `view`'s flags for `level` (`paper` or an id).
fn view_args(args: &BenchViewArgs, level: &str) -> anyhow::Result<ViewArgs> {
    let view = ViewArgs {
        checkpoint: args.checkpoint.clone(),
        window: args.window.clone(),
        episode: EpisodeArgs {
            seed: args.seed,
            level: (level != "paper").then(|| level.to_owned()),
            ..EpisodeArgs::default()
        },
        ..ViewArgs::default()
    };
    if let Some(id) = &view.episode.level {
        groundscope::env::LevelId::parse(id)?;
    }
    window_size(&view)?;
    Ok(view)
}

/// Opens the debugger on `level` without a window and times it (see the module doc).
fn time_level(args: &BenchViewArgs, level: &str) -> anyhow::Result<serde_json::Value> {
    let view = view_args(args, level)?;
    let [w, h] = window_size(&view)?;
    let input = || egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(
            egui::Pos2::ZERO,
            egui::vec2(w, h),
        )),
        ..egui::RawInput::default()
    };
    let started = Instant::now();
    let start = start_options(&view)?;
    let ctx = egui::Context::default();
    let mut debugger = Debugger::new(&start, None);
    let (mut first, mut frames) = (None, 0u64);
    let full = loop {
        let frame_start = Instant::now();
        let _ = ctx.run_ui(input(), |ui| debugger.frame(ui));
        frames += 1;
        if let Some((steps, complete)) = debugger.episode_progress() {
            if first.is_none() && steps > 0 {
                first = Some(started.elapsed());
            }
            if complete {
                break started.elapsed();
            }
        } else if let Some(e) = debugger.last_error() {
            anyhow::bail!("{e}");
        }
        if started.elapsed() > Duration::from_mins(10) {
            anyhow::bail!("the episode took more than 10 minutes");
        }
        std::thread::sleep(FRAME.saturating_sub(frame_start.elapsed()));
    };
    let steps = debugger.episode_progress().map_or(0, |(n, _)| n);
    let walked = walk(&ctx, &mut debugger, steps, args.walk_every_step, input);
    let round = |d: Duration| (d.as_secs_f64() * 1000.0).round() / 1000.0;
    Ok(serde_json::json!({
        "bench": "view",
        "level": level,
        "seed": args.seed,
        "checkpoint": start.request.checkpoint,
        "steps": steps,
        "time_to_first_frame_s": first.map(round),
        "time_to_full_episode_s": round(full),
        "frames_until_full": frames,
        "walked_steps": walked.frames,
        "walk_frame_ms": (walked.frame_ms * 10.0).round() / 10.0,
        "peak_rss_bytes": super::bench::peak_rss_bytes(),
        "rss_before_walk_bytes": walked.rss_before,
        "rss_after_walk_bytes": walked.rss_after,
        "walk_rss_growth_bytes_per_step": walked.growth_per_step(),
        "walk_samples": walked.samples,
        "threads": 1,
    }))
}

/// What a walk over an episode's steps measured.
struct Walk {
    /// Frames drawn, one per step walked.
    frames: u32,
    /// The mean time of a frame, in milliseconds.
    frame_ms: f64,
    /// The process's resident memory before the first frame of the walk.
    rss_before: Option<u64>,
    /// The process's resident memory after the last frame of the walk.
    rss_after: Option<u64>,
    /// A walk over every step: what the process held at [`WALK_SAMPLES`] points of it
    /// ([`walk_sample`]); empty otherwise.
    samples: Vec<serde_json::Value>,
}

impl Walk {
    /// How much the resident memory grew per step walked; `None` without `/proc`.
    fn growth_per_step(&self) -> Option<f64> {
        let (before, after) = self.rss_before.zip(self.rss_after)?;
        let per_step = (after as f64 - before as f64) / f64::from(self.frames.max(1));
        Some(per_step.round())
    }
}

/// Draws a frame at each of up to [`WALK_FRAMES`] evenly spaced steps of the `steps` the
/// episode has, or (`every_step`) at every step, sampling what the process holds as it goes.
/// The samples are read between frames, outside the frames' time.
fn walk(
    ctx: &egui::Context,
    debugger: &mut Debugger,
    steps: usize,
    every_step: bool,
    input: impl Fn() -> egui::RawInput,
) -> Walk {
    let stride = if every_step {
        1
    } else {
        steps.div_ceil(WALK_FRAMES).max(1)
    };
    let sample_every = steps.div_ceil(WALK_SAMPLES).max(1);
    let rss_before = super::bench::rss_bytes();
    let (mut frames, mut drawing, mut samples) = (0u32, Duration::ZERO, Vec::new());
    for k in (0..steps).step_by(stride) {
        let frame_start = Instant::now();
        debugger.go_to_step(k);
        let _ = ctx.run_ui(input(), |ui| debugger.frame(ui));
        drawing += frame_start.elapsed();
        frames += 1;
        if every_step && (k % sample_every == 0 || k + 1 == steps) {
            samples.push(walk_sample(ctx, debugger, k));
        }
    }
    Walk {
        frames,
        frame_ms: drawing.as_secs_f64() * 1000.0 / f64::from(frames.max(1)),
        rss_before,
        rss_after: super::bench::rss_bytes(),
        samples,
    }
}

/// What the process holds with step `k` shown: its resident memory, the textures egui has
/// allocated (the pictures' and the font atlas; their pixels live on the GPU, or nowhere
/// without a renderer) and the scenes the episode keeps.
fn walk_sample(ctx: &egui::Context, debugger: &Debugger, k: usize) -> serde_json::Value {
    let manager = ctx.tex_manager();
    let textures = manager.read();
    let texture_bytes: usize = textures.allocated().map(|(_, m)| m.bytes_used()).sum();
    serde_json::json!({
        "step": k,
        "rss_bytes": super::bench::rss_bytes(),
        "textures": textures.num_allocated(),
        "texture_bytes": texture_bytes,
        "scenes_kept": debugger
            .session()
            .shown
            .as_ref()
            .map(groundscope::app::session::Shown::scenes_kept),
    })
}
