//! `groundscope replay`: run a checkpoint on episodes and write what it saw and did — a JSON
//! trace, Rerun (file, spawned or running viewer), MCAP and/or a self-contained HTML page.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use anyhow::Context as _;
use clap::Args;
use groundscope::env::vocab::{tokenize, words};
use groundscope::episode::{EpisodeSpec, EpisodeTrace, initial_world, run_from};
use groundscope::metrics::faithfulness::annotate;
use groundscope::policy::Agent;
use groundscope::record::html::episode_page;
use groundscope::record::{
    McapRecorder, PendingFile, RecordError, RerunRecorder, RerunTargets, StopFlag, block_starts,
    mission_words, scene_block, word_paths,
};

use super::flags::EpisodeArgs;
use crate::ExitStatus;
use crate::cli::{check_distinct_outputs, check_extension};

/// The default `--connect` URL: a viewer on this machine.
const DEFAULT_VIEWER_URL: &str = "rerun+http://127.0.0.1:9876/proxy";

/// `groundscope replay`.
#[derive(Debug, Args)]
#[command(after_long_help = "EXAMPLES:\n  \
    groundscope replay --seed 3 --spawn\n  \
    groundscope replay --seed 3 --episodes 5 --save five.rrd --mcap five.mcap\n  \
    groundscope replay --checkpoint bundled:baseline --mission \"go to the red ball\" --save red.rrd\n  \
    groundscope replay --checkpoint runs/untrained --seed 3 --trace out.json\n  \
    groundscope replay --seed 3 --html ep.html --compare bundled:baseline\n  \
    groundscope replay --checkpoint my_agent.onnx --room-size 12 --faithfulness --save mine.rrd",
    // The room's old spelling here, kept for scripts (hidden).
    mut_arg("room_size", |a| a.alias("size")))]
pub struct ReplayArgs {
    /// Checkpoint: NAME (NAME.json + NAME.safetensors), a run directory (its model),
    /// bundled:attention / bundled:baseline / bundled:babyai / bundled:minigrid[-baseline], an
    /// ONNX graph FILE.onnx or `bot` (minigrid's BabyAI bot) [default: bundled:attention,
    /// bundled:babyai on a BabyAI level whose mission it cannot read, bundled:minigrid on
    /// MiniGrid's own ids].
    #[arg(long, value_name = "NAME")]
    pub checkpoint: Option<String>,
    /// Number of episodes, on consecutive seeds from --seed.
    #[arg(
        long,
        default_value_t = 1,
        value_name = "K",
        allow_negative_numbers = true
    )]
    pub episodes: u64,
    #[command(flatten)]
    pub episode: EpisodeArgs,
    /// Write the episode trace here (JSON; one episode only).
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// Write a Rerun recording (.rrd).
    #[arg(long, value_name = "FILE.rrd")]
    pub save: Option<PathBuf>,
    /// Start a Rerun viewer (`rerun` on PATH; `pip install rerun-sdk==0.36.3`) and stream to it.
    #[arg(long)]
    pub spawn: bool,
    /// Stream to a running Rerun viewer [URL default: rerun+http://127.0.0.1:9876/proxy].
    #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = DEFAULT_VIEWER_URL)]
    pub connect: Option<String>,
    /// Write the episodes as MCAP (Foxglove / Lichtblick).
    #[arg(long, value_name = "FILE.mcap")]
    pub mcap: Option<PathBuf>,
    /// Write the episode as one self-contained HTML page that opens offline in any browser:
    /// every step's world with M, view, word maps, action probabilities and instruction tree
    /// under a step slider (one episode only; docs/sharing.md).
    #[arg(long, value_name = "FILE.html")]
    pub html: Option<PathBuf>,
    /// With --html: run this checkpoint too on the same episode (level, seed, mission, mode)
    /// and show both side by side on one step axis.
    #[arg(long, value_name = "NAME")]
    pub compare: Option<String>,
    /// Add faithfulness measures to every step: occlusion Δ (7×7), ρ(M, Δ) and one-step
    /// interventions on M (in the trace, the `.rrd` and the MCAP; see docs/faithfulness.md).
    #[arg(long)]
    pub faithfulness: bool,
    /// Threshold fraction α of the grounding hit/miss marks (τ = α / n).
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub alpha: f64,
}

/// Refuses two outputs that name one file (`--save d.rrd --trace ./d.rrd`), before anything
/// is run or written: one would replace the other, and both would be said to be written.
fn check_outputs(args: &ReplayArgs) -> anyhow::Result<()> {
    let outputs: Vec<(&str, &std::path::Path)> = [
        ("--trace", args.trace.as_deref()),
        ("--save", args.save.as_deref()),
        ("--mcap", args.mcap.as_deref()),
        ("--html", args.html.as_deref()),
    ]
    .into_iter()
    .filter_map(|(flag, path)| path.map(|p| (flag, p)))
    .collect();
    check_distinct_outputs(&outputs)
}

/// Refuses flags no replay runs with, before anything is loaded or written.
fn check_args(args: &ReplayArgs) -> anyhow::Result<()> {
    if args.episodes == 0 {
        anyhow::bail!("--episodes 0: give at least one episode");
    }
    if args.trace.is_some() && args.episodes > 1 {
        anyhow::bail!("--trace writes one episode; drop --episodes or use --save / --mcap");
    }
    // One page is one episode: a page per seed is what `eval --html` writes for the episodes
    // worth a look, and a slider over several episodes would mix their step axes.
    if args.html.is_some() && args.episodes > 1 {
        anyhow::bail!("--html writes one episode; drop --episodes or use --save / --mcap");
    }
    if args.compare.is_some() && args.html.is_none() {
        anyhow::bail!(
            "--compare needs --html (the page shows both); the debugger compares with `view --compare`"
        );
    }
    if !(0.0..=1.0).contains(&args.alpha) {
        anyhow::bail!("--alpha {:?} is outside [0, 1]", args.alpha);
    }
    if let Some(p) = &args.save {
        check_extension(p, "rrd", "--save")?;
    }
    if let Some(p) = &args.mcap {
        check_extension(p, "mcap", "--mcap")?;
    }
    if let Some(p) = &args.html {
        check_extension(p, "html", "--html")?;
    }
    check_outputs(args)?;
    Ok(())
}

/// The page of `trace`, with the `compared` checkpoint's run of the same episode `spec`
/// beside it; and the longer episode's steps.
fn html_page(
    trace: &EpisodeTrace,
    compared: Option<&(String, Agent)>,
    spec: &EpisodeSpec,
    alpha: f64,
    stop: &StopFlag,
) -> anyhow::Result<(String, usize)> {
    // The second checkpoint on the very episode spec the first ran: same level, seed,
    // mission and action mode.
    let other = match compared {
        Some((name, a)) => Some(run_from(a.acting(), name, spec, initial_world(spec)?)?),
        None => None,
    };
    if stop.load(Ordering::Relaxed) {
        return Err(RecordError::Interrupted.into());
    }
    let mut shown = vec![trace];
    shown.extend(other.as_ref());
    let page = episode_page(&shown, alpha, Some(stop))?;
    let steps = shown.iter().map(|t| t.steps.len()).max().unwrap_or(0);
    Ok((page, steps))
}

/// Runs `replay`. Episodes are streamed: each is run, printed and recorded while the next
/// one runs, so memory does not grow with `--episodes`.
pub fn replay(args: &ReplayArgs) -> anyhow::Result<ExitStatus> {
    check_args(args)?;
    let stop: StopFlag = Arc::new(AtomicBool::new(false));
    {
        let s = stop.clone();
        // A second handler cannot be installed in the same process (tests call `run` once).
        let _ = ctrlc::set_handler(move || s.store(true, Ordering::Relaxed));
    }
    let (name, agent) = match &args.checkpoint {
        Some(name) => (name.clone(), Agent::load(name)?),
        None => super::default_model::for_episode(&args.episode, "replay")?,
    };
    // Loaded before anything runs: a checkpoint that does not load is an error, not a page
    // without its second panel.
    let compared = args
        .compare
        .as_deref()
        .map(|c| Agent::load(c).map(|a| (c.to_owned(), a)))
        .transpose()?;
    let level = args.episode.level(agent.level())?;
    let mode = args.episode.mode();
    let last = args
        .episode
        .seed
        .checked_add(args.episodes - 1)
        .context("--seed + --episodes overflows")?;
    let spec = |seed| EpisodeSpec {
        level,
        seed,
        mission: args.episode.mission.clone(),
        mode,
    };
    let wants_rerun = args.save.is_some() || args.spawn || args.connect.is_some();
    let n = usize::try_from(args.episodes).context("--episodes is too large")?;
    // The blueprint shows one view per word map of the whole recording: the missions come
    // from the levels alone, without running the policy.
    let mut paths = Vec::new();
    let variant = agent.acting().variant();
    if wants_rerun && variant.name() == "attention" {
        // One world per mission: the words that fold follow from its instruction.
        let mut missions = std::collections::BTreeMap::new();
        for seed in args.episode.seed..=last {
            if stop.load(Ordering::Relaxed) {
                return Err(RecordError::Interrupted.into());
            }
            let world = initial_world(&spec(seed))?;
            missions.entry(world.mission.clone()).or_insert(world);
        }
        let words = missions
            .iter()
            .map(|(m, world)| tokenize(m).map(|t| mission_words(words(&t), world)))
            .collect::<Result<Vec<_>, _>>()?;
        paths = word_paths(words);
    }
    // Destinations that can be checked before any work are checked now.
    let trace_file = args.trace.as_deref().map(PendingFile::new).transpose()?;
    let html_file = args.html.as_deref().map(PendingFile::new).transpose()?;
    let mut mcap = args.mcap.as_deref().map(McapRecorder::create).transpose()?;
    let mut rerun: Option<RerunRecorder> = None;
    let targets = RerunTargets {
        save: args.save.clone(),
        spawn: args.spawn,
        connect: args.connect.clone(),
    };
    let recording = wants_rerun || mcap.is_some();
    let t0 = Instant::now();
    let mut kept: Option<EpisodeTrace> = None;
    std::thread::scope(|scope| -> anyhow::Result<()> {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        let stop_worker = &stop;
        let (agent, name, spec) = (&agent, &name, &spec);
        let faithful = args.faithfulness.then(|| agent.acting());
        scope.spawn(move || {
            for seed in args.episode.seed..=last {
                if stop_worker.load(Ordering::Relaxed) {
                    break;
                }
                let item = initial_world(&spec(seed))
                    .and_then(|world| run_from(agent.acting(), name, &spec(seed), world))
                    .and_then(|mut trace| {
                        if let Some(acting) = faithful {
                            annotate(acting, &mut trace)?;
                        }
                        Ok(trace)
                    });
                let failed = item.is_err();
                if tx.send(item).is_err() || failed {
                    break;
                }
            }
        });
        for item in rx {
            let trace = item?;
            // An imported graph is named as its metadata names it, beside its file.
            let who = match &trace.model_name {
                Some(n) if agent.acting().reads_world() => n.clone(),
                Some(n) => format!("{n}, {}", variant.name()),
                // The checkpoint in full: "attention on …" read as bundled:attention.
                None => format!("{} ({})", trace.checkpoint, variant.name()),
            };
            println!(
                "{who} on {level} seed {}: \"{}\" → {} in {} steps, reward {:.3}",
                trace.seed,
                trace.mission,
                if trace.success() {
                    "success"
                } else {
                    "failure"
                },
                trace.steps.len(),
                trace.total_reward()
            );
            if wants_rerun && rerun.is_none() {
                rerun = Some(RerunRecorder::start(&targets, &trace, n, &paths)?);
            }
            // Block by block, each computed once for both formats and dropped once written:
            // memory stays flat whatever the episode's length.
            if recording {
                for first in block_starts(&trace) {
                    let scenes = scene_block(&trace, first, args.alpha);
                    if let Some(r) = &mut rerun {
                        r.push_block(&trace, first, &scenes, Some(&stop))?;
                    }
                    if let Some(m) = &mut mcap {
                        m.push_block(&trace, first, &scenes, Some(&stop))?;
                    }
                }
            }
            if args.trace.is_some() || args.html.is_some() {
                kept = Some(trace);
            }
        }
        Ok(())
    })?;
    if stop.load(Ordering::Relaxed) {
        return Err(RecordError::Interrupted.into());
    }
    // All outputs or none: each is finished under a temporary name beside its destination,
    // and they are renamed into place only once every one is complete. A failure before that
    // removes the temporary files alone: a file the user already had keeps its bytes.
    let mut pending: Vec<PendingFile> = Vec::new();
    let mut rerun_done = None;
    if let Some(r) = rerun {
        let (stats, file) = r.finish_pending()?;
        rerun_done = Some((stats, t0.elapsed().as_secs_f64()));
        pending.extend(file);
    }
    let mut mcap_stats = None;
    if let Some(m) = mcap {
        let (stats, file) = m.finish_pending()?;
        mcap_stats = Some(stats);
        pending.push(file);
    }
    if let (Some(file), Some(trace)) = (trace_file, &kept) {
        file.write_all(trace.to_json().as_bytes())?;
        pending.push(file);
    }
    let mut page_stats = None;
    if let (Some(file), Some(trace)) = (html_file, &kept) {
        let (page, steps) = html_page(
            trace,
            compared.as_ref(),
            &spec(trace.seed),
            args.alpha,
            &stop,
        )?;
        file.write_all(page.as_bytes())?;
        page_stats = Some((page.len(), steps));
        pending.push(file);
    }
    for file in pending {
        file.commit()?;
    }
    if let Some((stats, secs)) = rerun_done {
        if let Some(p) = &args.save {
            let bytes = std::fs::metadata(p).map_or(0, |m| m.len());
            println!(
                "wrote {} ({} episodes, {} steps, {bytes} bytes = {:.1} KB/step, {:.0} steps/s with the policy)",
                p.display(),
                stats.episodes,
                stats.steps,
                bytes as f64 / 1000.0 / stats.steps.max(1) as f64,
                stats.steps as f64 / secs.max(1e-9)
            );
        }
        if args.spawn || args.connect.is_some() {
            println!("streamed {} steps to the Rerun viewer", stats.steps);
        }
    }
    if let (Some(stats), Some(path)) = (mcap_stats, &args.mcap) {
        let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
        println!(
            "wrote {} ({} steps on {} topics, {bytes} bytes = {:.1} KB/step)",
            path.display(),
            stats.steps,
            stats.messages.len(),
            bytes as f64 / 1000.0 / stats.steps.max(1) as f64,
        );
    }
    if let (Some(path), Some(_)) = (&args.trace, &kept) {
        println!("wrote {}", path.display());
    }
    if let (Some(path), Some((bytes, steps))) = (&args.html, page_stats) {
        println!(
            "wrote {} ({steps} steps, {bytes} bytes = {:.1} KB/step)",
            path.display(),
            bytes as f64 / 1000.0 / steps.max(1) as f64
        );
    }
    Ok(ExitStatus::Success)
}
