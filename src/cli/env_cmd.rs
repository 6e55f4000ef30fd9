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
    /// BabyAI's registered mode: success without the `done` action (a registered id's
    /// default; the paper's level needs this flag for it).
    #[arg(long, conflicts_with = "done")]
    pub no_done: bool,
    /// The paper's done-action mode on a registered BabyAI id (the paper's level uses it
    /// without the flag).
    #[arg(long)]
    pub done: bool,
    /// Always name the colour in missions.
    #[arg(long)]
    pub always_color: bool,
    /// A level by its gym id (BabyAI-GoToObjMaze-v0, MiniGrid-DoorKey-5x5-v0) or a MiniGrid
    /// class with its arguments ("MultiRoomEnv(minNumRooms=7, maxNumRooms=7)"), generated
    /// exactly as minigrid 3.2.0 generates it; `--room-size`, `--objects` and `--tasks`
    /// describe the paper's level only. `groundscope env list` lists the ids.
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
            return Ok(LevelConfig::babyai(LevelId::parse(id)?, self.done));
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
    /// List every level id (BabyAI's 96 and MiniGrid's 76) with its family, rooms, actions,
    /// mechanics and mission words; with `--checkpoint`, whether that checkpoint can read
    /// each level's missions.
    #[command(
        after_long_help = "EXAMPLES:\n  groundscope env list\n  groundscope env list --checkpoint bundled:attention\n  groundscope env show --level BabyAI-KeyCorridorS3R3-v0 --seed 1"
    )]
    List {
        /// A checkpoint (NAME, run directory, bundled:…, FILE.onnx or bot): a last column
        /// says how many of each level's missions (seeds 0..200) it can read, and the first
        /// word it cannot.
        #[arg(long, value_name = "NAME")]
        checkpoint: Option<String>,
    },
    /// Replay dumps of the Python reference and compare every step.
    ///
    /// Each FILE is a dump_minigrid.py JSON episode (`.json`, or `.json.gz`). A dump of a
    /// BabyAI level or MiniGrid environment is first regenerated from its `env_id` and `seed` and its initial state
    /// compared (grid, agent pose, carried object, box contents, mission, instruction tree with
    /// matched positions); then its actions are replayed and every observation, reward,
    /// terminated/truncated flag, agent pose, carried object, changed grid and box contents is
    /// compared. Checks every file; prints the first mismatch of each failing one, a line for
    /// each that is bad input (exit 2), and ends with `N passed, M failed`.
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
        EnvCommand::List { checkpoint } => {
            let agent = checkpoint
                .as_deref()
                .map(groundscope::policy::Agent::load)
                .transpose()?;
            list(agent.as_ref());
            Ok(ExitStatus::Success)
        }
        EnvCommand::Verify { files } => Ok(verify(&files)),
    }
}

/// What `env show`'s grid letters mean (minigrid's `pprint_grid`).
const GRID_LEGEND: &str = "legend: two characters a cell, the object then its colour's initial \
(R red, G green or grey, B blue, P purple, Y yellow): W wall, K key, A ball, B box, D door \
(closed), L locked door, __ open door, G goal, V lava, F floor; the agent >>, VV, <<, ^^ \
facing right, down, left, up";

fn show(
    seed: u64,
    level: &LevelArgs,
    png: Option<PathBuf>,
    tile: u32,
    snapshot: Option<PathBuf>,
) -> anyhow::Result<ExitStatus> {
    let outputs: Vec<(&str, &std::path::Path)> = [
        ("--png", png.as_deref()),
        ("--snapshot", snapshot.as_deref()),
    ]
    .into_iter()
    .filter_map(|(flag, path)| path.map(|p| (flag, p)))
    .collect();
    crate::cli::check_distinct_outputs(&outputs)?;
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
    // minigrid's pprint_grid letters, which a reader cannot guess.
    println!("{GRID_LEGEND}");
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

/// Seeds whose missions `env list --checkpoint` reads per level.
const READ_SEEDS: u64 = 200;

/// How many of `level`'s missions (seeds 0..READ_SEEDS, registered mode) `agent` can read:
/// `all 200`, `150 of 200 (not "door")` or `none (not "put")`.
fn reads_level(
    agent: &groundscope::policy::Agent,
    spec: &groundscope::env::babyai::registry::LevelSpec,
) -> String {
    let Ok(id) = LevelId::parse(spec.id) else {
        return "?".into();
    };
    if agent.acting().reads_world() && id.minigrid().is_some() {
        return "none (BabyAI's bot plans BabyAI instructions only)".into();
    }
    let cfg = LevelConfig::babyai(id, false);
    let (mut ok, mut tried, mut first_unknown) = (0u64, 0u64, None);
    for seed in 0..READ_SEEDS {
        // A seed minigrid never finishes generating has no mission to read.
        let Ok(world) = cfg.generate(seed) else {
            continue;
        };
        tried += 1;
        let Ok(tokens) = groundscope::env::vocab::tokenize(&world.mission) else {
            continue;
        };
        match groundscope::policy::acting::unknown_word(agent.acting(), &tokens) {
            None => ok += 1,
            Some(t) => {
                first_unknown.get_or_insert(groundscope::env::vocab::word(t).unwrap_or("?"));
            }
        }
    }
    let not = first_unknown.map_or_else(String::new, |w| format!(" (not {w:?})"));
    if ok == tried {
        format!("all {tried}")
    } else if ok == 0 {
        format!("none{not}")
    } else {
        format!("{ok} of {tried}{not}")
    }
}

/// Seeds whose missions give a BabyAI level's words in `env list` (MiniGrid's classes list
/// their words themselves).
const WORD_SEEDS: u64 = 20;

/// The words `spec`'s missions use: a MiniGrid class's whole vocabulary, or the words of a
/// BabyAI level's missions over seeds 0..WORD_SEEDS.
fn mission_words(spec: &groundscope::env::babyai::registry::LevelSpec) -> String {
    if let groundscope::env::babyai::Family::MiniGrid(class) = spec.family {
        let words = class.mission_words();
        return if words.is_empty() {
            "(empty mission)".into()
        } else {
            words.join(" ")
        };
    }
    let mut words: Vec<String> = Vec::new();
    for seed in 0..WORD_SEEDS {
        if let Ok(w) = groundscope::env::babyai::generate(spec, seed, false) {
            for word in w.mission.split([' ', ',']).filter(|t| !t.is_empty()) {
                if !words.iter().any(|x| x == word) {
                    words.push(word.to_owned());
                }
            }
        }
    }
    words.join(" ")
}

fn list(agent: Option<&groundscope::policy::Agent>) {
    let reads_header = if agent.is_some() { "  reads" } else { "" };
    println!(
        "{:<40} {:<8} {:<19} {:>5} {:>6} {:>9} {:>7}  {:<18} {:<30} {:<36}  words{reads_header}",
        "id",
        "suite",
        "family",
        "rooms",
        "room",
        "grid",
        "actions",
        "doors",
        "locks",
        "instructions"
    );
    let mut readable = 0;
    let mut n = 0;
    for level in LevelId::all() {
        let l = level.spec();
        n += 1;
        let m = l.mechanics();
        let (grid, rooms, suite, family, actions) = if let Some(c) = level.minigrid() {
            let (w, h) = c.grid_size();
            let r = c.rooms();
            (
                format!("{w}×{h}"),
                format!("{}×{}", r.num_cols, r.num_rows),
                "MiniGrid",
                c.family().to_owned(),
                c.num_actions(),
            )
        } else {
            let (grid, rooms) = l.rooms.layout_names();
            // The family's class name (its variant, arguments left out).
            let family = format!("{:?}", l.family);
            let family = family
                .split([' ', '(', '{'])
                .next()
                .unwrap_or("")
                .to_owned();
            (
                grid,
                rooms,
                "BabyAI",
                family,
                groundscope::env::Action::COUNT,
            )
        };
        let reads = agent.map_or_else(String::new, |a| {
            let r = reads_level(a, l);
            readable += usize::from(r.starts_with("all"));
            format!("  {r}")
        });
        println!(
            "{:<40} {suite:<8} {family:<19} {rooms:>5} {:>6} {grid:>9} {actions:>7}  {:<18} {:<30} {:<36}  {}{reads}",
            l.id,
            l.rooms.room_size,
            m.doors,
            m.locks,
            m.instructions,
            mission_words(l)
        );
    }
    if agent.is_some() {
        println!(
            "the checkpoint reads every mission of {readable} of them (seeds 0..{READ_SEEDS})"
        );
    }
    println!(
        "{n} levels of minigrid 3.2.0: {} BabyAI, {} MiniGrid (its 6 MiniGrid-WFC-* ids do not \
         build from minigrid's wheel; a class with arguments is spelt \
         MultiRoomEnv(minNumRooms=7, maxNumRooms=7), docs/world.md)",
        LevelId::babyai_all().count(),
        LevelId::minigrid_all().count()
    );
}

fn verify(files: &[PathBuf]) -> ExitStatus {
    // Every file is checked: one that cannot be (unreadable, malformed, an unknown id) is bad
    // input, said in one line of its own, and does not stop the others.
    let (mut passed, mut failed, mut refused) = (0, 0, 0);
    for f in files {
        match verify_file(f) {
            Ok(None) => passed += 1,
            Ok(Some(m)) => {
                failed += 1;
                println!("{}: step {}: {}", f.display(), m.step, m.what);
            }
            Err(e) => {
                refused += 1;
                eprintln!("groundscope: {e:#}");
            }
        }
    }
    if refused == 0 {
        println!("{passed} passed, {failed} failed");
    } else {
        println!("{passed} passed, {failed} failed, {refused} refused (bad input)");
    }
    if refused > 0 {
        ExitStatus::BadInput
    } else if failed > 0 {
        ExitStatus::CheckFailed
    } else {
        ExitStatus::Success
    }
}

/// Reads, regenerates and replays one dump: its first mismatch, if any.
fn verify_file(f: &std::path::Path) -> anyhow::Result<Option<groundscope::env::Mismatch>> {
    let context = || format!("reading {}", f.display());
    let text = groundscope::files::read_text_maybe_gz(f).with_context(context)?;
    let snap = Snapshot::from_json(&text).with_context(context)?;
    if let Err(m) = verify_dump(&snap).with_context(context)? {
        return Ok(Some(m));
    }
    // A dump with minigrid's bot's suggestions (`--record-bot`) checks ours too.
    Ok(groundscope::bot::verify_bot(&snap)
        .with_context(context)?
        .and_then(Result::err))
}
