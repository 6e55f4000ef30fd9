//! Exploration coverage (issue #30 item 2, beyond the paper): how much of the room an
//! evaluated episode covered, how it moved, and what the attention maps did while no target
//! was in view. The failure classes say *that* big-room failures never see the target; these
//! numbers say whether the agent searched (covered the floor) or spun and looped in place.
//!
//! A [`Tracker`] reads the same per-step facts as the failure classifier
//! ([`super::failure::StepFacts`]: the world before the action, the observation the policy got,
//! `M`, the action) plus the word attentions of the trace, so it never re-runs the policy;
//! [`Tracker::finish`] gives one [`EpisodeExploration`] per episode. [`cell_exploration`]
//! aggregates a cell's episodes into mean ± std **over episodes** (not over seeds as the
//! performance tables are: the failures of one seed are too few to average per seed), for all
//! episodes and split by outcome. The report writes them as `exploration.csv`, two `report.md`
//! tables, a `report.json` `exploration` object per cell and two figures (the `report`
//! submodule). Definitions: `docs/exploration.md`.

use serde::{Deserialize, Serialize};

use super::failure::StepFacts;
use super::grounding::pending_targets;
use super::sweep::{EpisodeSummary, MeanStd};
use crate::env::grid::Pos;
use crate::env::view::{VIEW_SIZE, ViewCell, world_from_view};
use crate::env::world::Action;
use crate::episode::EpisodeTrace;
use crate::policy::{ViewMap, WordAttention};

/// Cells of a map: entropies are divided by `ln 49`, the entropy of a uniform map.
const MAP_CELLS: usize = VIEW_SIZE * VIEW_SIZE;

/// The maps over a set of steps of one episode (those with a target visible, or those
/// without): per-step values averaged over the steps; `None` where no step had one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MapStats {
    /// Steps in the set.
    pub steps: u32,
    /// Mean normalised entropy of `M`, `H(M) / ln 49` (0 = one cell, 1 = uniform).
    pub m_entropy: Option<f64>,
    /// Mean of `M`'s largest value.
    pub m_max: Option<f64>,
    /// Mean normalised entropy of the word weights, `H(w) / ln m` over the m mission words
    /// (0 = one word carries `M`, 1 = all weigh the same); steps with one word are left out.
    pub w_entropy: Option<f64>,
    /// Mean over steps of the words' mean normalised map entropy, `H_i / ln 49`.
    pub word_entropy: Option<f64>,
}

/// The maps of an attention episode, split by whether a target was visible at the step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MapSplit {
    /// Steps with no target visible.
    pub hidden: MapStats,
    /// Steps with a target visible.
    pub visible: MapStats,
}

/// The exploration statistics of one episode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EpisodeExploration {
    /// Steps (actions) taken.
    pub steps: u32,
    /// The room's floor cells: the grid's interior, `(W − 2)·(H − 2)`, `(S − 2)²` for an S×S
    /// room.
    pub floor_cells: u32,
    /// Distinct floor cells the agent stood on, the cell it ended on included.
    pub visited: u32,
    /// `visited / floor_cells`.
    pub visited_frac: f64,
    /// Share of the floor cells that were ever a visible cell of an observation the policy
    /// got (the agent's own cell included; occluded cells are not visible).
    pub seen_frac: f64,
    /// Share of the steps whose action was `left` or `right`.
    pub turn_frac: f64,
    /// The longest run of consecutive `left`/`right` actions.
    pub longest_turn_run: u32,
    /// Share of the steps whose pose (cell and direction, before the action) the agent had
    /// already held at an earlier step of the episode.
    pub revisit_frac: f64,
    /// The first step (0-based) whose observation showed a target; `None` if none did.
    pub first_visible_step: Option<u32>,
    /// The last step reached the step limit (rather than the agent ending the episode with
    /// `done` or a `pickup`/`toggle` that finished the task, successfully or not).
    #[serde(default)]
    pub truncated: bool,
    /// The maps while a target was hidden / visible (`None` without attention).
    pub maps: Option<MapSplit>,
}

/// Running sums of one side of the [`MapSplit`].
#[derive(Clone, Copy, Debug, Default)]
struct MapSums {
    steps: u32,
    /// (sum, count) of H(M)/ln 49, max M, H(w)/ln m, mean H_i/ln 49.
    parts: [(f64, u32); 4],
}

impl MapSums {
    fn add(&mut self, m: &ViewMap, words: &[WordAttention]) {
        self.steps = self.steps.saturating_add(1);
        let flat = m.iter().flatten().map(|&v| f64::from(v));
        let max = flat.clone().fold(f64::NEG_INFINITY, f64::max);
        let word_h: Vec<f64> = words
            .iter()
            .map(|w| f64::from(w.entropy) / (MAP_CELLS as f64).ln())
            .filter(|h| h.is_finite())
            .collect();
        let values = [
            normalised_entropy(flat),
            max.is_finite().then_some(max),
            normalised_entropy(words.iter().map(|w| f64::from(w.weight))),
            (!word_h.is_empty())
                .then(|| (word_h.iter().sum::<f64>() / word_h.len() as f64).clamp(0.0, 1.0)),
        ];
        for (part, v) in self.parts.iter_mut().zip(values) {
            if let Some(v) = v {
                part.0 += v;
                part.1 += 1;
            }
        }
    }

    fn stats(&self) -> MapStats {
        let mean = |(s, n): (f64, u32)| (n > 0).then(|| s / f64::from(n));
        MapStats {
            steps: self.steps,
            m_entropy: mean(self.parts[0]),
            m_max: mean(self.parts[1]),
            w_entropy: mean(self.parts[2]),
            word_entropy: mean(self.parts[3]),
        }
    }
}

/// `H(p) / ln n` of the n values, rescaled to sum 1 first (a trace's maps and weights sum to 1
/// up to rounding; an imported graph's need not), clamped to [0, 1]. `None` for fewer than two
/// values, a non-positive or non-finite sum, or a negative value.
fn normalised_entropy(values: impl Iterator<Item = f64> + Clone) -> Option<f64> {
    let n = values.clone().count();
    let total: f64 = values.clone().sum();
    if n < 2 || !(total.is_finite() && total > 0.0) || values.clone().any(|v| v < 0.0) {
        return None;
    }
    let h: f64 = values
        .map(|v| v / total)
        .filter(|&p| p > 0.0)
        .map(|p| -p * p.ln())
        .sum();
    let v = h / (n as f64).ln();
    v.is_finite().then(|| v.clamp(0.0, 1.0))
}

/// Accumulates one episode step by step; [`Tracker::finish`] gives its
/// [`EpisodeExploration`]. Cells are kept as flags over the grid, so a step costs one pass
/// over the 49 view cells.
#[derive(Clone, Debug, Default)]
pub struct Tracker {
    width: i32,
    height: i32,
    /// Per grid cell (x-major): ever a visible view cell.
    seen: Vec<bool>,
    /// Per grid cell: stood on.
    stood: Vec<bool>,
    /// Per grid cell: a bit per direction held there before an action.
    poses: Vec<u8>,
    steps: u32,
    turns: u32,
    run: u32,
    longest_run: u32,
    revisits: u32,
    first_visible: Option<u32>,
    truncated: bool,
    with_maps: bool,
    hidden: MapSums,
    visible: MapSums,
}

impl Tracker {
    /// The index of a floor cell (inside the wall ring) of the grid, else `None`.
    fn floor_index(&self, (x, y): Pos) -> Option<usize> {
        let inside = (1..self.width - 1).contains(&x) && (1..self.height - 1).contains(&y);
        inside.then(|| (x * self.height + y) as usize)
    }

    /// Adds one step: `step` as the failure classifier reads it, `words` the trace's word
    /// attentions (`None` without attention).
    pub fn push(&mut self, step: &StepFacts<'_>, words: Option<&[WordAttention]>) {
        self.push_seeing(step, words, &pending_targets(step.world, step.obs));
    }

    /// [`Tracker::push`] with the step's visible targets already found
    /// (`pending_targets(step.world, step.obs)`), as the sweep passes them.
    pub fn push_seeing(
        &mut self,
        step: &StepFacts<'_>,
        words: Option<&[WordAttention]>,
        targets: &[ViewCell],
    ) {
        let world = step.world;
        if self.seen.is_empty() {
            // The grid's size is fixed for an episode (edits never resize it).
            self.width = world.grid.width() as i32;
            self.height = world.grid.height() as i32;
            let n = world.grid.width() * world.grid.height();
            self.seen = vec![false; n];
            self.stood = vec![false; n];
            self.poses = vec![0; n];
        }
        if let Some(i) = self.floor_index(world.agent_pos) {
            self.stood[i] = true;
            let bit = 1u8 << (world.agent_dir & 3);
            if self.poses[i] & bit != 0 {
                self.revisits += 1;
            }
            self.poses[i] |= bit;
        }
        for vy in 0..VIEW_SIZE {
            for vx in 0..VIEW_SIZE {
                if !step.obs.visible((vx, vy)) {
                    continue;
                }
                let pos = world_from_view(world.agent_pos, world.agent_dir, (vx, vy));
                if let Some(i) = self.floor_index(pos) {
                    self.seen[i] = true;
                }
            }
        }
        let target_visible = !targets.is_empty();
        if target_visible && self.first_visible.is_none() {
            self.first_visible = Some(self.steps);
        }
        if matches!(step.action, Action::Left | Action::Right) {
            self.turns += 1;
            self.run += 1;
            self.longest_run = self.longest_run.max(self.run);
        } else {
            self.run = 0;
        }
        if let Some(m) = step.combined {
            self.with_maps = true;
            let side = if target_visible {
                &mut self.visible
            } else {
                &mut self.hidden
            };
            side.add(m, words.unwrap_or_default());
        }
        self.truncated = step.truncated;
        self.steps = self.steps.saturating_add(1);
    }

    /// The episode's statistics; `final_pos` is where the last action left the agent (it
    /// counts as visited). An episode without steps has zeros throughout.
    pub fn finish(mut self, final_pos: Pos) -> EpisodeExploration {
        if let Some(i) = self.floor_index(final_pos) {
            self.stood[i] = true;
        }
        let floor = (self.width - 2).max(0) as u32 * (self.height - 2).max(0) as u32;
        let count = |v: &[bool]| v.iter().filter(|&&b| b).count() as u32;
        let frac = |n: u32, d: u32| {
            if d == 0 {
                0.0
            } else {
                f64::from(n) / f64::from(d)
            }
        };
        let visited = count(&self.stood);
        EpisodeExploration {
            steps: self.steps,
            floor_cells: floor,
            visited,
            visited_frac: frac(visited, floor),
            seen_frac: frac(count(&self.seen), floor),
            turn_frac: frac(self.turns, self.steps),
            longest_turn_run: self.longest_run,
            revisit_frac: frac(self.revisits, self.steps),
            first_visible_step: self.first_visible,
            truncated: self.truncated,
            maps: self.with_maps.then(|| MapSplit {
                hidden: self.hidden.stats(),
                visible: self.visible.stats(),
            }),
        }
    }

    /// The statistics of a recorded episode (`groundscope replay --trace`, the debugger): the
    /// same numbers the sweep computes for the same episode.
    pub fn from_trace(trace: &EpisodeTrace) -> EpisodeExploration {
        let mut t = Self::default();
        for s in &trace.steps {
            t.push(
                &StepFacts {
                    world: &s.world,
                    obs: &s.obs,
                    combined: s.attention.as_ref().map(|a| &a.combined),
                    action: s.action,
                    reward: s.reward,
                    terminated: s.terminated,
                    truncated: s.truncated,
                },
                s.attention.as_ref().map(|a| a.words.as_slice()),
            );
        }
        t.finish(trace.final_world.agent_pos)
    }
}

/// [`MapStats`] of a cell: each per-episode mean, then mean ± std over the episodes that had
/// such steps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellMapStats {
    /// Steps in the set, over all episodes.
    pub steps: u64,
    /// `H(M) / ln 49`.
    pub m_entropy: MeanStd,
    /// `max M`.
    pub m_max: MeanStd,
    /// `H(w) / ln m`.
    pub w_entropy: MeanStd,
    /// Mean `H_i / ln 49` of the words.
    pub word_entropy: MeanStd,
}

/// [`MapSplit`] of a cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellMapSplit {
    /// Steps with no target visible.
    pub hidden: CellMapStats,
    /// Steps with a target visible.
    pub visible: CellMapStats,
}

/// A cell's exploration over a set of episodes: every per-episode number as mean ± std over
/// the episodes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExplorationStats {
    /// Episodes in the set.
    pub episodes: u64,
    /// Steps per episode.
    pub steps: MeanStd,
    /// Floor cells stood on.
    pub visited: MeanStd,
    /// Share of the floor stood on.
    pub visited_frac: MeanStd,
    /// Share of the floor ever seen.
    pub seen_frac: MeanStd,
    /// Share of turning steps.
    pub turn_frac: MeanStd,
    /// Longest run of turns.
    pub longest_turn_run: MeanStd,
    /// Share of steps in a pose held before.
    pub revisit_frac: MeanStd,
    /// First step with a target visible, over the episodes that had one.
    pub first_visible_step: MeanStd,
    /// Episodes in which no target was ever visible.
    pub never_visible: u64,
    /// Episodes that reached the step limit.
    #[serde(default)]
    pub truncated: u64,
    /// The maps (`None` without attention).
    pub maps: Option<CellMapSplit>,
}

/// A cell's exploration: all episodes, the successes and the failures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellExploration {
    /// Every episode.
    pub all: ExplorationStats,
    /// The successful episodes.
    pub success: ExplorationStats,
    /// The failed episodes.
    pub failure: ExplorationStats,
}

impl CellExploration {
    /// The three sets with their `exploration.csv` names, in file order.
    pub fn outcomes(&self) -> [(&'static str, &ExplorationStats); 3] {
        [
            ("all", &self.all),
            ("success", &self.success),
            ("failure", &self.failure),
        ]
    }
}

/// Mean ± std over episodes of the values `f` gives (episodes where it gives `None` are left
/// out).
fn over<T>(eps: &[&T], f: impl Fn(&T) -> Option<f64>) -> MeanStd {
    MeanStd::of(&eps.iter().filter_map(|e| f(e)).collect::<Vec<_>>())
}

fn cell_maps(eps: &[&EpisodeExploration], side: fn(&MapSplit) -> &MapStats) -> CellMapStats {
    let sides: Vec<&MapStats> = eps
        .iter()
        .filter_map(|e| e.maps.as_ref())
        .map(side)
        .collect();
    CellMapStats {
        steps: sides.iter().map(|s| u64::from(s.steps)).sum(),
        m_entropy: over(&sides, |s| s.m_entropy),
        m_max: over(&sides, |s| s.m_max),
        w_entropy: over(&sides, |s| s.w_entropy),
        word_entropy: over(&sides, |s| s.word_entropy),
    }
}

/// The statistics of a set of episodes.
pub fn exploration_stats(eps: &[&EpisodeExploration]) -> ExplorationStats {
    ExplorationStats {
        episodes: eps.len() as u64,
        steps: over(eps, |e| Some(f64::from(e.steps))),
        visited: over(eps, |e| Some(f64::from(e.visited))),
        visited_frac: over(eps, |e| Some(e.visited_frac)),
        seen_frac: over(eps, |e| Some(e.seen_frac)),
        turn_frac: over(eps, |e| Some(e.turn_frac)),
        longest_turn_run: over(eps, |e| Some(f64::from(e.longest_turn_run))),
        revisit_frac: over(eps, |e| Some(e.revisit_frac)),
        first_visible_step: over(eps, |e| e.first_visible_step.map(f64::from)),
        never_visible: eps
            .iter()
            .filter(|e| e.first_visible_step.is_none())
            .count() as u64,
        truncated: eps.iter().filter(|e| e.truncated).count() as u64,
        maps: eps.iter().any(|e| e.maps.is_some()).then(|| CellMapSplit {
            hidden: cell_maps(eps, |m| &m.hidden),
            visible: cell_maps(eps, |m| &m.visible),
        }),
    }
}

/// A cell's exploration from its episodes, each summary with its exploration (as
/// [`super::sweep::evaluate_cell_explored`] returns them); the outcome split reads
/// `success`.
pub fn cell_exploration(eps: &[(EpisodeSummary, EpisodeExploration)]) -> CellExploration {
    let pick = |keep: &dyn Fn(&EpisodeSummary) -> bool| {
        let set: Vec<&EpisodeExploration> = eps
            .iter()
            .filter(|(s, _)| keep(s))
            .map(|(_, e)| e)
            .collect();
        exploration_stats(&set)
    };
    CellExploration {
        all: pick(&|_| true),
        success: pick(&|s| s.success),
        failure: pick(&|s| !s.success),
    }
}

mod report;
pub use report::{EXPLORATION_CSV_HEADER, FIG_EXPLORATION, FIG_EXPLORATION_MAPS};

#[cfg(test)]
mod tests;
