//! `groundscope bench bot`: minigrid's BabyAI bot alone, one thread — demonstrations (whole
//! episodes from reset, the bot's every action) per second on each level, in the level's
//! registered mode, seeds 0..N. `experiments/bot_speed/run.sh` times minigrid's own bot on
//! the same levels and seeds beside it.

use std::time::Instant;

use clap::Args;
use groundscope::bot::Expert;
use groundscope::env::{LevelConfig, LevelId};

use crate::ExitStatus;

/// The levels timed by default: one room, several rooms, PutNext, locked doors, the
/// synthesised grammar and BossLevel.
const DEFAULT_LEVELS: &str = "BabyAI-GoToLocal-v0,BabyAI-GoTo-v0,BabyAI-PutNextLocal-v0,\
BabyAI-UnlockPickup-v0,BabyAI-SynthS5R2-v0,BabyAI-BossLevel-v0";

/// `bench bot`'s flags.
#[derive(Debug, Args)]
pub struct BenchBotArgs {
    /// BabyAI ids, comma-separated.
    #[arg(long, value_name = "IDS", default_value = DEFAULT_LEVELS)]
    levels: String,
    /// Episodes (seeds 0..N) per level.
    #[arg(long, default_value_t = 500, allow_negative_numbers = true)]
    episodes: u64,
}

/// Runs the benchmark: one JSON line per level.
pub fn run(args: &BenchBotArgs) -> anyhow::Result<ExitStatus> {
    if !(1..=1_000_000).contains(&args.episodes) {
        anyhow::bail!("--episodes {}: must be in 1..=1000000", args.episodes);
    }
    let ids = args
        .levels
        .split(',')
        .map(|s| LevelId::parse(s.trim()))
        .collect::<Result<Vec<_>, _>>()?;
    for id in ids {
        let cfg = LevelConfig::babyai(id, false);
        let (mut steps, mut successes, mut gave_up, mut endless) = (0u64, 0u64, 0u64, 0u64);
        let start = Instant::now();
        for seed in 0..args.episodes {
            // A seed minigrid itself never finishes generating is counted, not played.
            let mut world = match cfg.generate(seed) {
                Err(groundscope::env::EnvError::GenerationHangs { .. }) => {
                    endless += 1;
                    continue;
                }
                other => other?,
            };
            let mut expert = Expert::new(&world);
            loop {
                let Some(action) = expert.advise(&world, &world.observe()) else {
                    gave_up += 1;
                    break;
                };
                let out = world.step(action)?;
                expert.told(action);
                steps += 1;
                if out.terminated || out.truncated {
                    successes += u64::from(out.reward > 0.0);
                    break;
                }
            }
        }
        let secs = start.elapsed().as_secs_f64();
        let line = serde_json::json!({
            "bench": "bot",
            "level": id.id(),
            "episodes": args.episodes,
            "steps": steps,
            "success": successes as f64 / args.episodes as f64,
            "gave_up": gave_up,
            "endless_seeds": endless,
            "demos_per_sec": (args.episodes as f64 / secs * 10.0).round() / 10.0,
            "steps_per_sec": (steps as f64 / secs).round(),
            "threads": 1,
            "elapsed_secs": secs,
        });
        println!("{line}");
    }
    Ok(ExitStatus::Success)
}
