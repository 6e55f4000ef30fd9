//! `groundscope env …`: show generated levels, verify dumps from the Python reference.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use groundscope::env::{LevelConfig, LevelId, Snapshot, TaskSet, verify_dump};

use crate::ExitStatus;

/// Level flags shared by every command that generates worlds.
#[derive(Clone, Debug, Args)]
pub struct LevelArgs {
    /// Room side S, walls included (the paper trains on 8; `--size` is still accepted).
    #[arg(
        long = "room-size",
        alias = "size",
        value_name = "S",
        default_value_t = 8,
        allow_negative_numbers = true
    )]
    pub size: usize,
    /// Number of objects N (the paper trains on 4).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 4,
        allow_negative_numbers = true
    )]
    pub objects: usize,
    /// Task kinds: goto, pickup or both.
    #[arg(long, value_name = "KINDS", default_value = "both")]
    pub tasks: String,
    /// BabyAI's default mode: success without the `done` action.
    #[arg(long)]
    pub no_done: bool,
    /// Always name the colour in missions.
    #[arg(long)]
    pub always_color: bool,
    /// A BabyAI level by its gym id (e.g. BabyAI-GoToObjMaze-v0), generated exactly as
    /// minigrid 3.2.0 generates it; `--room-size`, `--objects` and `--tasks` describe the
    /// paper's level only. `groundscope env list` lists the ids.
    #[arg(
        long,
        value_name = "ID",
        conflicts_with_all = ["size", "objects", "tasks", "always_color"]
    )]
    pub level: Option<String>,
}

impl LevelArgs {
    /// The level these flags describe, validated.
    pub fn config(&self) -> anyhow::Result<LevelConfig> {
        if let Some(id) = &self.level {
            return Ok(LevelConfig::babyai(LevelId::parse(id)?, !self.no_done));
        }
        let cfg = LevelConfig {
            room_size: self.size,
            n_objects: self.objects,
            tasks: TaskSet::parse(&self.tasks)?,
            done_required: !self.no_done,
            color_optional: !self.always_color,
            babyai: None,
        };
        cfg.validate()?;
        Ok(cfg)
    }
}

/// `env` subcommands.
#[derive(Debug, Subcommand)]
pub enum EnvCommand {
    /// Print a generated level (ASCII grid and mission), optionally as a PNG or snapshot.
    #[command(
        after_long_help = "EXAMPLES:\n  groundscope env show --seed 3\n  groundscope env show --seed 3 --png level.png --snapshot level.json"
    )]
    Show {
        /// Level seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        #[command(flatten)]
        level: LevelArgs,
        /// Write the rendered world here (PNG).
        #[arg(long, value_name = "FILE")]
        png: Option<PathBuf>,
        /// Tile size of the PNG in pixels.
        #[arg(long, default_value_t = 32)]
        tile: u32,
        /// Write the world state here (dump_minigrid.py JSON format).
        #[arg(long, value_name = "FILE")]
        snapshot: Option<PathBuf>,
    },
    /// List every BabyAI level id with its rooms and mechanics.
    #[command(
        after_long_help = "EXAMPLES:\n  groundscope env list\n  groundscope env show --level BabyAI-KeyCorridorS3R3-v0 --seed 1"
    )]
    List,
    /// Replay dumps of the Python reference and compare every step.
    ///
    /// Each FILE is a dump_minigrid.py JSON episode (`.json`, or `.json.gz`). A dump of a
    /// BabyAI level is first regenerated from its `env_id` and `seed` and its initial state
    /// compared (grid, agent pose, carried object, box contents, mission, instruction tree with
    /// matched positions); then its actions are replayed and every observation, reward,
    /// terminated/truncated flag, agent pose, carried object, changed grid and box contents is
    /// compared. Prints the first mismatch of each failing file and ends with `N passed, M
    /// failed`.
    #[command(
        after_long_help = "EXAMPLES:\n  groundscope env verify tests/fixtures/minigrid/*.json"
    )]
    Verify {
        /// Dump files.
        #[arg(required = true, value_name = "FILE")]
        files: Vec<PathBuf>,
    },
}

/// Runs an `env` subcommand.
pub fn run(cmd: EnvCommand) -> anyhow::Result<ExitStatus> {
    match cmd {
        EnvCommand::Show {
            seed,
            level,
            png,
            tile,
            snapshot,
        } => show(seed, &level, png, tile, snapshot),
        EnvCommand::List => {
            list();
            Ok(ExitStatus::Success)
        }
        EnvCommand::Verify { files } => verify(&files),
    }
}

fn show(
    seed: u64,
    level: &LevelArgs,
    png: Option<PathBuf>,
    tile: u32,
    snapshot: Option<PathBuf>,
) -> anyhow::Result<ExitStatus> {
    let cfg = level.config()?;
    let world = cfg.generate(seed)?;
    let env_id = cfg
        .babyai
        .map_or_else(|| cfg.to_string(), |id| id.id().to_owned());
    let snap = Snapshot::from_world(&world, Some(env_id), Some(seed));
    println!("level: {cfg}  seed: {seed}  max_steps: {}", world.max_steps);
    println!("mission: {}", world.mission);
    for line in &snap.grid_ascii {
        println!("{line}");
    }
    if let Some(path) = png {
        if !(4..=256).contains(&tile) {
            anyhow::bail!("--tile {tile} is outside 4..=256");
        }
        let img = groundscope::render::render_world(&world, tile, true);
        groundscope::render::save_png(&img, &path)?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = snapshot {
        groundscope::policy::checkpoint::write_atomic(&path, snap.to_json().as_bytes())?;
        println!("wrote {}", path.display());
    }
    Ok(ExitStatus::Success)
}

fn list() {
    let levels = groundscope::env::babyai::registry::LEVELS;
    println!(
        "{:<36} {:>5} {:>6} {:>9}  {:<18} {:<26} instructions",
        "id", "rooms", "room", "grid", "doors", "locks"
    );
    for l in levels {
        let m = l.mechanics();
        let (w, h) = l.rooms.grid_size();
        println!(
            "{:<36} {:>5} {:>6} {:>9}  {:<18} {:<26} {}",
            l.id,
            format!("{}×{}", l.rooms.num_cols, l.rooms.num_rows),
            l.rooms.room_size,
            format!("{w}×{h}"),
            m.doors,
            m.locks,
            m.instructions
        );
    }
    println!("{} levels (minigrid 3.2.0)", levels.len());
}

fn verify(files: &[PathBuf]) -> anyhow::Result<ExitStatus> {
    // Read and parse everything first: an unreadable file is bad input (exit 2), not a mismatch.
    let mut dumps = Vec::with_capacity(files.len());
    for f in files {
        let text = groundscope::files::read_text_maybe_gz(f)
            .with_context(|| format!("reading {}", f.display()))?;
        let snap =
            Snapshot::from_json(&text).with_context(|| format!("reading {}", f.display()))?;
        dumps.push((f, snap));
    }
    let (mut passed, mut failed) = (0, 0);
    for (f, snap) in &dumps {
        let checked = verify_dump(snap).and_then(|r| match r {
            // A dump with minigrid's bot's suggestions (`--record-bot`) checks ours too.
            Ok(n) => Ok(groundscope::bot::verify_bot(snap)?.unwrap_or(Ok(n))),
            Err(m) => Ok(Err(m)),
        });
        match checked.with_context(|| format!("reading {}", f.display()))? {
            Ok(_) => passed += 1,
            Err(m) => {
                failed += 1;
                println!("{}: step {}: {}", f.display(), m.step, m.what);
            }
        }
    }
    println!("{passed} passed, {failed} failed");
    Ok(if failed == 0 {
        ExitStatus::Success
    } else {
        ExitStatus::CheckFailed
    })
}
