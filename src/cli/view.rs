//! `groundscope view` (and `groundscope` with no arguments): the interactive debugger.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use groundscope::app::episodes::Browser;
use groundscope::app::{self, EpisodeRequest, Launch, WindowOptions};

use super::flags::EpisodeArgs;
use crate::ExitStatus;
use crate::cli::check_extension;

/// `groundscope view`.
#[derive(Debug, Args, Default)]
#[command(
    after_long_help = "KEYS:\n  ← / →  step back / forward    space  play / pause    Home / End  first / last step\n\n\
EXAMPLES:\n  groundscope\n  groundscope view --seed 7 --compare bundled:baseline\n  \
groundscope view --report report/   (an eval --out folder: N / P next / previous failure)\n  \
groundscope view --checkpoint my_agent.onnx --compare bundled:attention\n  \
xvfb-run -a groundscope view --screenshot shot.png --seed 3 --step 4 --window 1400x900"
)]
pub struct ViewArgs {
    /// Checkpoint: NAME (NAME.json + NAME.safetensors), a run directory (its model),
    /// bundled:attention / bundled:baseline / bundled:babyai / bundled:minigrid[-baseline], an
    /// ONNX graph FILE.onnx (docs/onnx.md) or `bot` (minigrid's BabyAI bot) [default:
    /// bundled:attention, bundled:babyai on a BabyAI level whose mission it cannot read,
    /// bundled:minigrid on MiniGrid's own ids].
    #[arg(long, value_name = "NAME")]
    pub checkpoint: Option<String>,
    /// A second checkpoint (any form --checkpoint takes), run on the same seed side by side.
    #[arg(long, value_name = "NAME")]
    pub compare: Option<String>,
    /// Step shown first.
    #[arg(
        long,
        default_value_t = 0,
        value_name = "K",
        allow_negative_numbers = true
    )]
    pub step: usize,
    #[command(flatten)]
    pub episode: EpisodeArgs,
    /// Window size in logical pixels (`--size` is still accepted).
    #[arg(long, alias = "size", value_name = "WxH", default_value = "1400x900")]
    pub window: String,
    /// Render one frame of the debugger to this PNG and exit (needs a display; use xvfb-run
    /// on a headless machine).
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// Open with the faithfulness view (occlusion map, ρ, interventions, probes) shown.
    #[arg(long)]
    pub faithfulness: bool,
    /// Browse an evaluation (the folder `eval --out` wrote) in the episodes panel: filter and
    /// sort its episodes, N / P for the next or previous failure, a click to open one at the
    /// step where it was lost. Opens its first failure; its episodes name their checkpoint,
    /// level and seed.
    #[arg(
        long,
        value_name = "DIR",
        conflicts_with_all = ["checkpoint", "mission", "seed", "level", "room_size", "objects", "step", "sample"]
    )]
    pub report: Option<PathBuf>,
}

fn parse_size(s: &str) -> anyhow::Result<[f32; 2]> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("--window {s:?} is not WIDTHxHEIGHT, e.g. 1400x900"))?;
    let parse = |v: &str| -> anyhow::Result<f32> {
        let n: u32 = v
            .trim()
            .parse()
            .with_context(|| format!("--window {s:?}: {v:?} is not a whole number of pixels"))?;
        if !(200..=8192).contains(&n) {
            anyhow::bail!("--window {s:?}: {n} is outside 200..=8192 pixels");
        }
        Ok(n as f32)
    };
    Ok([parse(w)?, parse(h)?])
}

/// Runs `view`.
pub fn run(args: &ViewArgs) -> anyhow::Result<ExitStatus> {
    let size = window_size(args)?;
    if let Some(p) = &args.screenshot {
        check_extension(p, "png", "--screenshot")?;
    }
    let launch = start_options(args)?;
    app::run(
        &launch,
        &WindowOptions {
            size,
            screenshot: args.screenshot.clone(),
        },
    )?;
    if let Some(p) = &args.screenshot {
        println!("wrote {}", p.display());
    }
    Ok(ExitStatus::Success)
}

/// The window's size from `--window`.
pub fn window_size(args: &ViewArgs) -> anyhow::Result<[f32; 2]> {
    // `groundscope` with no arguments builds `ViewArgs::default()`, whose size is empty.
    if args.window.is_empty() {
        Ok([1400.0, 900.0])
    } else {
        parse_size(&args.window)
    }
}

/// What the debugger opens with: the checkpoint (or the default one for the level), level,
/// seed and mission, each checked here.
pub fn start_options(args: &ViewArgs) -> anyhow::Result<Launch> {
    if let Some(dir) = &args.report {
        return report_options(args, dir);
    }
    // Load once here so that a bad checkpoint or level is a one-line error, not a window.
    let (checkpoint, agent) = match &args.checkpoint {
        Some(c) => (c.clone(), groundscope::policy::Agent::load(c)?),
        None => super::default_model::for_episode(&args.episode, "view")?,
    };
    if let Some(c) = &args.compare {
        groundscope::policy::Agent::load(c)?;
    }
    let level = args.episode.level(agent.level())?;
    if let Some(m) = &args.episode.mission {
        groundscope::env::parse_mission(m)?;
    }
    Ok(Launch {
        request: EpisodeRequest {
            checkpoint,
            level,
            seed: args.episode.seed,
            mode: args.episode.mode(),
            step: args.step,
            mission: args.episode.mission.clone(),
        },
        compare: args.compare.clone(),
        faithfulness: args.faithfulness,
        report: None,
    })
}

/// `view --report DIR`: the evaluation read and its first failure (else first episode) opened,
/// its checkpoint loaded here so that a report that cannot open is a one-line error; a Python
/// policy's episode has none to load, and opens read-only ([`Launch::from_report`]).
fn report_options(args: &ViewArgs, dir: &std::path::Path) -> anyhow::Result<Launch> {
    let browser = Browser::open(dir)?;
    let first = browser
        .first()
        .with_context(|| format!("--report {}: episodes.csv lists no episode", dir.display()))?;
    // A Python policy's episodes are replayed read-only: there is no checkpoint to load.
    let python = browser.is_python(first);
    let mut launch = Launch::from_report(browser)?;
    if !python {
        let ep = &launch.request;
        groundscope::policy::Agent::load(&ep.checkpoint)
            .with_context(|| format!("--report {}: checkpoint {}", dir.display(), ep.checkpoint))?;
    }
    if let Some(c) = &args.compare {
        groundscope::policy::Agent::load(c)?;
    }
    launch.compare.clone_from(&args.compare);
    launch.faithfulness = args.faithfulness;
    Ok(launch)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser as _;

    /// Parses `groundscope view ARGS`.
    fn view_args(args: &[&str]) -> ViewArgs {
        let cli =
            crate::cli::Cli::try_parse_from(["groundscope", "view"].iter().chain(args)).unwrap();
        match cli.command {
            Some(crate::cli::Command::View(v)) => *v,
            _ => panic!("not a view command"),
        }
    }

    /// Without `--checkpoint` the paper's model opens wherever it reads the mission, and
    /// `bundled:babyai` where it does not.
    #[test]
    fn the_default_model_is_one_that_reads_the_mission() {
        assert_eq!(
            super::super::default_model::for_episode(&view_args(&[]).episode, "view")
                .unwrap()
                .0,
            "bundled:attention"
        );
        assert_eq!(
            super::super::default_model::for_episode(
                &view_args(&["--level", "BabyAI-GoToLocal-v0"]).episode,
                "view"
            )
            .unwrap()
            .0,
            "bundled:attention"
        );
        for id in [
            "BabyAI-GoToDoor-v0",
            "BabyAI-OpenDoor-v0",
            "BabyAI-UnlockLocal-v0",
        ] {
            assert_eq!(
                super::super::default_model::for_episode(
                    &view_args(&["--level", id, "--seed", "2"]).episode,
                    "view"
                )
                .unwrap()
                .0,
                groundscope::policy::bundled::BABYAI,
                "{id}"
            );
        }
    }
}
