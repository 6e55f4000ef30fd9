//! Flags that several commands share, defined once (`#[command(flatten)]`) so that a flag
//! means the same everywhere: the evaluation sweep (`eval`, `faithfulness`, `bench onnx`) and
//! the episode a replay shows (`replay`, `view`). The level flags of `env` and `train` are
//! [`super::env_cmd::LevelArgs`]. A command that needs another default changes it with
//! `#[command(mut_arg(...))]`, and help says so.

use std::ops::Range;

use clap::Args;
use groundscope::env::LevelConfig;
use groundscope::env::seeds::{EPISODES_PER_EVAL_SEED, MAX_EVAL_SEEDS};
use groundscope::episode::ActionMode;

/// The evaluation sweep: its cells (room sizes × object counts), seeds, episodes and how
/// actions are chosen.
#[derive(Args, Clone, Debug)]
pub struct SweepArgs {
    /// Room sizes of the sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "8,10,12,14,16",
        allow_negative_numbers = true
    )]
    pub sizes: Vec<usize>,
    /// Object counts of the sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "4,6,8,10",
        allow_negative_numbers = true
    )]
    pub objects: Vec<usize>,
    /// Evaluation seeds per cell (mean ± std is over these).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    pub seeds: u64,
    /// The first evaluation seed: the sweep uses seeds S .. S + --seeds − 1. Reports so far
    /// use seeds from 0; a later S gives levels none of them has seen (held-out levels).
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0,
        allow_negative_numbers = true
    )]
    pub first_seed: u64,
    /// Episodes per seed.
    #[arg(long, default_value_t = 100, allow_negative_numbers = true)]
    pub episodes: u64,
    /// Sample actions instead of taking the most probable one.
    #[arg(long)]
    pub sample: bool,
    /// Registered BabyAI levels to sweep instead of the paper's sizes and object counts,
    /// comma-separated (`groundscope env list`): each level × seeds × episodes, as minigrid
    /// registers it (no `done` action; `--done` for the paper's done-action mode).
    #[arg(
        long,
        visible_alias = "level",
        value_name = "ID,ID,...",
        value_delimiter = ',',
        conflicts_with_all = ["sizes", "objects"]
    )]
    pub levels: Vec<String>,
    /// The done-action mode on every level (the paper's: success only on `done` right after
    /// the instruction is satisfied); a registered BabyAI id runs without it by default.
    #[command(flatten)]
    pub done: DoneArgs,
}

/// The one switch for the done-action mode, shared by every command that runs a level.
#[derive(Args, Clone, Copy, Debug, Default)]
pub struct DoneArgs {
    /// The paper's done-action mode on any level: success only on `done` right after the
    /// instruction is satisfied (the paper's level uses it without the flag; a registered
    /// BabyAI id, as `gym.make(id)`, does not).
    #[arg(long, conflicts_with = "no_done")]
    pub done: bool,
    /// BabyAI's registered mode on any level: success as soon as the instruction is
    /// satisfied, no `done` action (the default of a registered BabyAI id).
    #[arg(long)]
    pub no_done: bool,
}

impl DoneArgs {
    /// The done-action setting of a level whose default is `default`.
    fn resolve(self, default: bool) -> bool {
        if self.done {
            true
        } else if self.no_done {
            false
        } else {
            default
        }
    }

    /// `level` with the switch applied: a registered BabyAI id defaults to its registered
    /// mode (no `done`), the paper's level to `level`'s own setting.
    pub fn apply(self, level: LevelConfig) -> LevelConfig {
        let default = level.babyai.is_none() && level.done_required;
        LevelConfig {
            done_required: self.resolve(default),
            ..level
        }
    }
}

impl SweepArgs {
    /// Refuses a sweep that cannot run, naming the flag, before anything is loaded.
    pub fn check(&self) -> anyhow::Result<()> {
        if self.sizes.is_empty() || self.objects.is_empty() || self.seeds == 0 || self.episodes == 0
        {
            anyhow::bail!(
                "the sweep is empty: --sizes, --objects, --seeds and --episodes must each give at least one"
            );
        }
        if self.episodes >= EPISODES_PER_EVAL_SEED {
            anyhow::bail!(
                "--episodes {} must be below 1000000 (level seeds are seed·10⁶ + episode)",
                self.episodes
            );
        }
        // Level seeds s·10⁶ + e must stay under the tracked evaluation's 2³¹ (and training's
        // 2³²).
        if self
            .first_seed
            .checked_add(self.seeds)
            .is_none_or(|end| end > MAX_EVAL_SEEDS)
        {
            anyhow::bail!(
                "--first-seed {} --seeds {} reaches past evaluation seed {} (level seeds are seed·10⁶ + episode, below 2³¹)",
                self.first_seed,
                self.seeds,
                MAX_EVAL_SEEDS - 1
            );
        }
        Ok(())
    }

    /// Refuses levels no model can be swept on, before any checkpoint is loaded: an unknown
    /// or repeated `--levels` id, or a room of `--sizes` × `--objects` that cannot hold its
    /// objects (checked on the paper's level, as a model of the paper's level is swept).
    pub fn check_levels(&self) -> anyhow::Result<()> {
        self.levels(LevelConfig::default())?;
        Ok(())
    }

    /// The evaluation seeds, `--first-seed` .. `--first-seed + --seeds`.
    pub fn seed_range(&self) -> Range<u64> {
        self.first_seed..self.first_seed + self.seeds
    }

    /// Greedy, or sampled with `--sample`.
    pub fn mode(&self) -> ActionMode {
        action_mode(self.sample)
    }

    /// The sweep's levels for a model trained on `base`: the `--levels` given; else, for a
    /// model of a BabyAI level, its own level; else the paper's level at every `--sizes` ×
    /// `--objects`, room sizes outermost, each checked (an error names the cell's flags).
    pub fn levels(&self, base: LevelConfig) -> anyhow::Result<Vec<LevelConfig>> {
        if !self.levels.is_empty() {
            return Ok(babyai_levels(&self.levels, base)?
                .into_iter()
                .map(|l| self.done.apply(l))
                .collect());
        }
        // A model trained on a BabyAI level is swept on its own level.
        if base.babyai.is_some() {
            return Ok(vec![self.done.apply(base)]);
        }
        Ok(paper_levels(base, &self.sizes, &self.objects)?
            .into_iter()
            .map(|l| self.done.apply(l))
            .collect())
    }
}

/// The episode a command shows: its level seed, mission, room and how actions are chosen.
/// `Default` gives the command line's defaults.
#[derive(Args, Clone, Debug, Default)]
pub struct EpisodeArgs {
    /// Level seed (of the first episode).
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    pub seed: u64,
    /// Replace the generated mission (vocabulary words only).
    #[arg(long, value_name = "TEXT")]
    pub mission: Option<String>,
    /// Sample actions instead of taking the most probable one.
    #[arg(long)]
    pub sample: bool,
    /// Room side S, walls included; defaults to the level the checkpoint was trained on.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub room_size: Option<usize>,
    /// Number of objects; defaults to the checkpoint's level.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub objects: Option<usize>,
    /// A level by its gym id (`groundscope env list`: BabyAI's or MiniGrid's), or a MiniGrid
    /// class with its arguments, instead of the paper's, as minigrid registers it (no `done`
    /// action; `--done` for BabyAI's done-action mode).
    #[arg(
        long,
        visible_alias = "levels",
        value_name = "ID",
        conflicts_with_all = ["room_size", "objects"]
    )]
    pub level: Option<String>,
    /// `--done` / `--no-done`.
    #[command(flatten)]
    pub done: DoneArgs,
}

impl EpisodeArgs {
    /// Greedy, or sampled with `--sample`.
    pub fn mode(&self) -> ActionMode {
        action_mode(self.sample)
    }

    /// The checkpoint's level `base` with `--room-size` and `--objects` applied, checked.
    pub fn level(&self, base: LevelConfig) -> anyhow::Result<LevelConfig> {
        if let Some(id) = &self.level {
            let id = groundscope::env::LevelId::parse(id)?;
            return Ok(self.done.apply(LevelConfig::babyai(id, false)));
        }
        let level = super::policy_cmd::level_from(base, self.room_size, self.objects)?;
        Ok(self.done.apply(level))
    }
}

/// The BabyAI levels `ids` (as `--levels` gives them) in their registered mode (no `done`);
/// an unknown or repeated id is an error naming it.
pub fn babyai_levels(ids: &[String], base: LevelConfig) -> anyhow::Result<Vec<LevelConfig>> {
    let mut out = Vec::new();
    for id in ids {
        let id = groundscope::env::level::LevelId::parse(id.trim())
            .map_err(|e| anyhow::anyhow!("--levels: {e}"))?;
        if out.iter().any(|l: &LevelConfig| l.babyai == Some(id)) {
            anyhow::bail!("--levels: {} is listed twice", id.id());
        }
        // A registered id is `gym.make(id)`: no `done` action unless a `--done` is applied.
        out.push(LevelConfig {
            babyai: Some(id),
            done_required: false,
            ..base
        });
    }
    Ok(out)
}

/// The paper's level at every room size × object count, room sizes outermost, each checked
/// (an error names the cell's flags).
pub fn paper_levels(
    base: LevelConfig,
    sizes: &[usize],
    objects: &[usize],
) -> anyhow::Result<Vec<LevelConfig>> {
    let mut levels = Vec::with_capacity(sizes.len() * objects.len());
    for &size in sizes {
        for &n in objects {
            levels.push(super::policy_cmd::sweep_level(base, size, n)?);
        }
    }
    Ok(levels)
}

fn action_mode(sample: bool) -> ActionMode {
    if sample {
        ActionMode::Sampled
    } else {
        ActionMode::Greedy
    }
}
