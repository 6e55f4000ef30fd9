//! `groundscope bench …`: speed benchmarks printing one JSON line each.

use std::hint::black_box;
use std::time::Instant;

use clap::Subcommand;
use groundscope::env::{Action, LevelConfig};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::ExitStatus;

/// `bench` subcommands.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Environment speed, one thread: resets/s (level generation and first observation), then
    /// steps/s of random actions with auto-reset, observation included; the paper's level or
    /// `--level ID`.
    Env {
        /// Steps to time.
        #[arg(long, default_value_t = 5_000_000, allow_negative_numbers = true)]
        steps: u64,
        /// Resets (level generations) to time on their own.
        #[arg(long, default_value_t = 20_000, allow_negative_numbers = true)]
        resets: u64,
        /// A level by its gym id, BabyAI's or MiniGrid's, or a MiniGrid class with its
        /// arguments (default: the paper's level), in its registered mode.
        #[arg(long, value_name = "ID")]
        level: Option<String>,
        /// `--done` / `--no-done`, as every command that runs a level takes them.
        #[command(flatten)]
        done: super::flags::DoneArgs,
    },
    /// Policy speed, one thread: batched inference steps/s at batch 1, 16 (a rollout step) and
    /// 256, training forward+backward frames/s on PPO minibatches (128, 256 and 2048 frames,
    /// `--recurrence`), and the GFLOP/s of the network's largest product alone.
    Policy {
        /// attention or baseline.
        #[arg(long, default_value = "attention")]
        model: String,
        /// Seconds to spend on each measurement.
        #[arg(long, default_value_t = 3.0, allow_negative_numbers = true)]
        secs: f64,
        /// BPTT chunk length of the training minibatches (`train --recurrence`).
        #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
        recurrence: usize,
    },
    /// PPO training end to end from a fresh network on the paper's level, with the wall time
    /// of each phase (rollout: env, encoding, forward; GAE; update: encoding, forward,
    /// backward, optimizer), as one JSON line.
    Train {
        /// attention or baseline.
        #[arg(long, default_value = "attention")]
        model: String,
        /// Frames to train (whole updates of 2,048 frames).
        #[arg(long, default_value_t = 40_960, allow_negative_numbers = true)]
        frames: u64,
        /// Thread counts to time (`train --threads`), e.g. 1,2: one JSON line each, then one
        /// with each count's speed over the first's.
        #[arg(
            long,
            alias = "update-threads",
            value_name = "N,..",
            default_value = "1"
        )]
        threads: String,
    },
    /// Studies on this machine's cores: `--runs` trainings of the paper's recipe (one thread
    /// each, as a study's runs), first one alone and then all at once; the aggregate frames/s
    /// of each, their ratio and each run's peak memory.
    Study {
        /// Concurrent runs [default: one per core].
        #[arg(long, allow_negative_numbers = true)]
        runs: Option<i64>,
        /// Frames each run trains (whole updates of 2,048 frames).
        #[arg(long, default_value_t = 20_480, allow_negative_numbers = true)]
        frames: u64,
    },
    /// Recording speed and size: the bundled attention checkpoint's episodes on consecutive
    /// seeds written as `.rrd` and as MCAP (episodes are run first and not timed); with
    /// `--level`, one long episode (BossLevel seed 3: 1,728 steps) recorded as `replay` does,
    /// each format in a process of its own: time to write and peak memory against running
    /// alone.
    Record(super::bench_record::BenchRecordArgs),
    /// An ONNX graph against a native checkpoint: the evaluation sweep (default: the default
    /// sweep, 10,000 greedy episodes) on each, alternated, one thread; the ratio of their
    /// times and where the graph's time goes (tract's plan, building its inputs and reading
    /// its outputs, the rest: world, metrics).
    #[cfg(feature = "onnx")]
    Onnx(super::bench_onnx::BenchOnnxArgs),
    /// The evaluation sweep over BabyAI levels (default: twenty the bundled models can read)
    /// against the paper's 20-cell sweep, alternated, one thread: time per episode step of
    /// each and their ratio, as one JSON line.
    Levels(super::bench_levels::BenchLevelsArgs),
    /// The default evaluation sweep as `groundscope eval --out DIR` runs it, every measure
    /// included, in a process of its own: its wall time, its episodes' and the rest's (the
    /// worst episodes' re-runs, tables, figures, report), as one JSON line.
    Sweep(super::bench_sweep::BenchSweepArgs),
    /// minigrid's BabyAI bot alone, one thread: demonstrations/s and steps/s per level
    /// (default: six levels from one room to BossLevel), in each level's registered mode, as
    /// one JSON line per level.
    Bot(super::bench_bot::BenchBotArgs),
    /// The debugger opening an episode without a window, each level in its own process
    /// (default: the paper's level and BossLevel, seed 3): time to the first frame showing
    /// step 0, time until the whole episode is in, a frame's time over the episode's steps
    /// and peak memory, as one JSON line per level and one with them side by side.
    View(super::bench_view::BenchViewArgs),
}

/// Runs a benchmark.
pub fn run(cmd: &BenchCommand) -> anyhow::Result<ExitStatus> {
    match cmd {
        BenchCommand::Env {
            steps,
            resets,
            level,
            done,
        } => bench_env(*steps, *resets, level.as_deref(), *done),
        BenchCommand::Train {
            model,
            frames,
            threads,
        } => bench_train_counts(model, *frames, threads),
        BenchCommand::Study { runs, frames } => super::study_run::bench_study(
            *frames,
            match runs {
                Some(n) => super::study_run::count("--runs", *n)?,
                None => std::thread::available_parallelism().map_or(1, std::num::NonZero::get),
            },
        ),
        BenchCommand::Policy {
            model,
            secs,
            recurrence,
        } => {
            if !(secs.is_finite() && *secs > 0.0 && *secs <= 3600.0) {
                anyhow::bail!("--secs {secs:?}: must be a number of seconds in (0, 3600]");
            }
            if !matches!(recurrence, 1 | 2 | 4 | 8 | 16 | 32 | 64 | 128 | 256) {
                anyhow::bail!("--recurrence {recurrence}: must be a power of two in 1..=256");
            }
            bench_policy(model, *secs, *recurrence)
        }
        #[cfg(feature = "onnx")]
        BenchCommand::Onnx(args) => super::bench_onnx::run(args),
        BenchCommand::Levels(args) => super::bench_levels::run(args),
        BenchCommand::Sweep(args) => super::bench_sweep::run(args),
        BenchCommand::Bot(args) => super::bench_bot::run(args),
        BenchCommand::View(args) => super::bench_view::run(args),
        BenchCommand::Record(args) => super::bench_record::run(args),
    }
}

fn bench_env(
    steps: u64,
    resets: u64,
    level: Option<&str>,
    done: super::flags::DoneArgs,
) -> anyhow::Result<ExitStatus> {
    if steps == 0 {
        anyhow::bail!("--steps 0: must be at least 1");
    }
    if resets == 0 {
        anyhow::bail!("--resets 0: must be at least 1");
    }
    let cfg = done.apply(match level {
        Some(id) => LevelConfig::babyai(groundscope::env::LevelId::parse(id)?, false),
        None => LevelConfig::default(),
    });
    // Seeds minigrid loops forever on have no level: passed over, and counted.
    let mut endless = 0u64;
    let mut generate = |seed: u64| -> anyhow::Result<Option<groundscope::env::World>> {
        match cfg.generate(seed) {
            Err(groundscope::env::EnvError::GenerationHangs { .. }) => {
                endless += 1;
                Ok(None)
            }
            w => Ok(Some(w?)),
        }
    };
    let start = Instant::now();
    for seed in 0..resets {
        black_box(generate(seed)?.map(|w| w.observe()));
    }
    let reset_secs = start.elapsed().as_secs_f64();
    let mut rng = Pcg64Mcg::seed_from_u64(0);
    let mut seed = 0;
    let mut next = |seed: &mut u64| -> anyhow::Result<groundscope::env::World> {
        loop {
            if let Some(w) = generate(*seed)? {
                return Ok(w);
            }
            *seed += 1;
        }
    };
    let mut world = next(&mut seed)?;
    let mut episodes = 1u64;
    let start = Instant::now();
    for _ in 0..steps {
        let action = Action::ALL[rng.random_range(0..Action::COUNT)];
        let out = world.step(action)?;
        black_box(world.observe());
        if out.terminated || out.truncated {
            seed += 1;
            episodes += 1;
            world = next(&mut seed)?;
        }
    }
    let secs = start.elapsed().as_secs_f64();
    let line = serde_json::json!({
        "bench": "env",
        "steps_per_sec": (steps as f64 / secs).round(),
        "resets_per_sec": (resets as f64 / reset_secs).round(),
        "resets": resets,
        "level": cfg.to_string(),
        "steps": steps,
        "episodes": episodes,
        "endless_seeds": endless,
        "threads": 1,
        "elapsed_secs": secs,
    });
    println!("{line}");
    Ok(ExitStatus::Success)
}

/// Repeats `f` for about `secs` seconds (after one warm-up call); returns calls per second.
fn rate(secs: f64, mut f: impl FnMut() -> anyhow::Result<()>) -> anyhow::Result<f64> {
    f()?;
    let start = Instant::now();
    let mut n = 0u64;
    while start.elapsed().as_secs_f64() < secs {
        f()?;
        n += 1;
    }
    Ok(n as f64 / start.elapsed().as_secs_f64())
}

fn bench_policy(model: &str, secs: f64, rec: usize) -> anyhow::Result<ExitStatus> {
    use groundscope::env::vocab::tokenize;
    use groundscope::policy::obs::{CellCodes, TokenBatch};
    use groundscope::policy::ppo::{PpoConfig, ppo_loss};
    use groundscope::policy::{ActOptions, Memory, ModelConfig, Net, Params, act};

    let threads = std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "default".into());
    let variant = crate::cli::policy_cmd::parse_variant(model)?;
    let cfg = ModelConfig::new(variant);
    let params = Params::init(&cfg, 0)?;
    let level = LevelConfig::default();
    let worlds: Vec<_> = (0..2048)
        .map(|s| level.generate(s))
        .collect::<Result<_, _>>()?;
    let tokens: Vec<Vec<u32>> = worlds
        .iter()
        .map(|w| tokenize(&w.mission))
        .collect::<Result<_, _>>()?;
    let obs: Vec<_> = worlds
        .iter()
        .map(groundscope::env::World::observe)
        .collect();
    let net = Net::new(cfg, params.detached())?;
    for batch in [1usize, 16, 256] {
        let missions: Vec<&[u32]> = tokens[..batch].iter().map(Vec::as_slice).collect();
        let mem = Memory::zeros(batch, cfg.lstm_hidden)?;
        let calls = rate(secs, || {
            act(&net, &obs[..batch], &missions, &mem, ActOptions::default())?;
            Ok(())
        })?;
        println!(
            "{}",
            serde_json::json!({"bench": "policy_inference", "model": variant.name(), "batch": batch,
                "steps_per_sec": (calls * batch as f64).round(), "calls_per_sec": calls, "threads": threads})
        );
    }
    let train_net = Net::new(cfg, params.tracked())?;
    let ppo = PpoConfig::default();
    // 128 frames: a minibatch's shard on two threads (`train --threads 2`); a minibatch holds
    // at least one sequence of `rec` frames.
    for frames in [128usize, 256, 2048].into_iter().filter(|&f| f >= rec) {
        let n = frames / rec;
        let missions: Vec<&[u32]> = tokens[..frames].iter().map(Vec::as_slice).collect();
        let p = CellCodes::new(&obs[..frames]);
        let keep = candle_core::Tensor::ones(
            (rec, n),
            candle_core::DType::F32,
            &candle_core::Device::Cpu,
        )?;
        let mem = Memory::zeros(n, cfg.lstm_hidden)?;
        let zeros =
            candle_core::Tensor::zeros(frames, candle_core::DType::F32, &candle_core::Device::Cpu)?;
        let actions = candle_core::Tensor::zeros(
            (frames, 1),
            candle_core::DType::U32,
            &candle_core::Device::Cpu,
        )?;
        let calls = rate(secs, || {
            let tb = TokenBatch::new(&missions)?;
            let (logits, values, _) = train_net.sequence(&p, &tb, &mem, &keep)?;
            let l = ppo_loss(
                &logits, &values, &actions, &zeros, &zeros, &zeros, &zeros, &ppo,
            )?;
            l.total.backward()?;
            Ok(())
        })?;
        println!(
            "{}",
            serde_json::json!({"bench": "policy_train_fwd_bwd", "model": variant.name(), "minibatch_frames": frames,
                "recurrence": rec, "frames_per_sec": (calls * frames as f64).round(), "threads": threads})
        );
    }
    bench_matmul(&cfg, secs, &threads)?;
    Ok(ExitStatus::Success)
}

/// The network's largest product, the LSTM input projection `(rows × 784) · (784 × 512)`,
/// alone through candle's matmul: the arithmetic rate this core's gemm reaches, against which
/// the training figures read (gemm's kernels are about half of a training thread's time).
fn bench_matmul(
    cfg: &groundscope::policy::ModelConfig,
    secs: f64,
    threads: &str,
) -> anyhow::Result<()> {
    use candle_core::{Device, Tensor};
    let (k, n) = (
        groundscope::policy::obs::N_CELLS * cfg.conv_channels,
        4 * cfg.lstm_hidden,
    );
    let w_t = Tensor::randn(0f32, 1.0, (k, n), &Device::Cpu)?;
    for rows in [128usize, 256, 2048] {
        let x = Tensor::randn(0f32, 1.0, (rows, k), &Device::Cpu)?;
        let calls = rate(secs, || {
            black_box(x.matmul(&w_t)?);
            Ok(())
        })?;
        let flops = 2.0 * (rows * k * n) as f64;
        println!(
            "{}",
            serde_json::json!({"bench": "policy_matmul", "rows": rows, "inner": k, "columns": n,
                "gflops": (calls * flops / 1e8).round() / 10.0, "threads": threads})
        );
    }
    Ok(())
}

/// `bench train --threads A,B,..`: every count timed in turn, then their speed ratios.
fn bench_train_counts(model: &str, frames: u64, list: &str) -> anyhow::Result<ExitStatus> {
    if !(2048..=10_000_000).contains(&frames) {
        anyhow::bail!("--frames {frames}: must be in 2048..=10000000");
    }
    let mut counts = Vec::new();
    for item in list.split(',').map(str::trim) {
        match item.parse::<usize>() {
            Ok(n) if (1..=64).contains(&n) => counts.push(n),
            _ => anyhow::bail!("--threads {list}: {item:?} is not a thread count in 1..=64"),
        }
    }
    let variant = crate::cli::policy_cmd::parse_variant(model)?;
    let mut speeds = Vec::new();
    for &n in &counts {
        speeds.push((n, bench_train(variant, frames, n)?));
    }
    if speeds.len() > 1 {
        let ratios: serde_json::Map<String, serde_json::Value> = speed_over_first(&speeds)
            .into_iter()
            .map(|(n, r)| {
                (
                    n.to_string(),
                    serde_json::json!((r * 1000.0).round() / 1000.0),
                )
            })
            .collect();
        println!(
            "{}",
            serde_json::json!({"bench": "train-scaling", "model": variant.name(),
                "speed_over_first": ratios, "first_threads": counts[0]})
        );
    }
    Ok(ExitStatus::Success)
}

/// Each thread count's speed over the first count's, in the order the counts first appear: a
/// count listed several times (`1,2,1,2`, alternating against the machine's drift) stands for
/// the median of its runs, the first count's too.
fn speed_over_first(speeds: &[(usize, f64)]) -> Vec<(usize, f64)> {
    let median_of = |n: usize| {
        let mut runs: Vec<f64> = speeds.iter().filter(|s| s.0 == n).map(|s| s.1).collect();
        runs.sort_by(f64::total_cmp);
        let mid = runs.len() / 2;
        if runs.len().is_multiple_of(2) {
            f64::midpoint(runs[mid - 1], runs[mid])
        } else {
            runs[mid]
        }
    };
    let Some(&(first, _)) = speeds.first() else {
        return Vec::new();
    };
    let base = median_of(first);
    let mut out: Vec<(usize, f64)> = Vec::new();
    for &(n, _) in speeds {
        if !out.iter().any(|o| o.0 == n) {
            out.push((n, median_of(n) / base));
        }
    }
    out
}

/// Trains `frames` with `threads` threads and prints one JSON line; returns frames/s.
fn bench_train(
    variant: groundscope::policy::Variant,
    frames: u64,
    threads: usize,
) -> anyhow::Result<f64> {
    use groundscope::policy::ppo::{PpoConfig, Trainer};
    use groundscope::policy::{ModelConfig, Params};

    let cfg = ModelConfig::new(variant);
    let ppo = PpoConfig {
        threads,
        ..PpoConfig::default()
    };
    let mut trainer = Trainer::new(cfg, LevelConfig::default(), ppo, Params::init(&cfg, 0)?, 0)?;
    let start = Instant::now();
    while trainer.state.frames < frames {
        trainer.update()?;
    }
    let total = start.elapsed().as_secs_f64();
    let mut phases = serde_json::Map::new();
    let mut timed = 0.0;
    for (name, secs) in trainer.times.named() {
        timed += secs;
        phases.insert(
            name.to_owned(),
            serde_json::json!((secs * 1000.0).round() / 1000.0),
        );
    }
    let candle = std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "default".into());
    let fps = trainer.state.frames as f64 / total;
    println!(
        "{}",
        serde_json::json!({"bench": "train", "model": variant.name(), "frames": trainer.state.frames,
            "frames_per_sec": fps.round(), "seconds": total,
            "phase_seconds": phases, "untimed_seconds": total - timed,
            "threads": threads, "candle_threads": candle})
    );
    Ok(fps)
}

/// The process's peak resident memory (`VmHWM`), in bytes; `None` where `/proc` has none.
pub(super) fn peak_rss_bytes() -> Option<u64> {
    status_bytes("VmHWM:")
}

/// The process's resident memory now (`VmRSS`), in bytes; `None` where `/proc` has none.
/// Unlike the peak it shows growth after the peak was reached (a walk over an episode's
/// steps once the episode is in).
pub(super) fn rss_bytes() -> Option<u64> {
    status_bytes("VmRSS:")
}

/// A `kB` figure of `/proc/self/status` (`field` with its colon), in bytes.
fn status_bytes(field: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    let kb: u64 = line
        .trim_start_matches(field)
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Alternating counts compare medians: the first count's drift (100, 110, 90) and the
    /// second's (170, 160) give 165 / 100, not the last run over the first.
    #[test]
    fn repeated_thread_counts_compare_medians() {
        let speeds = [(1, 100.0), (2, 170.0), (1, 110.0), (2, 160.0), (1, 90.0)];
        let r = speed_over_first(&speeds);
        assert_eq!(r.len(), 2);
        assert_eq!(r[0], (1, 1.0));
        assert_eq!(r[1].0, 2);
        assert!((r[1].1 - 1.65).abs() < 1e-12, "{r:?}");
        assert_eq!(
            speed_over_first(&[(4, 50.0), (1, 25.0)]),
            vec![(4, 1.0), (1, 0.5)]
        );
    }
}
