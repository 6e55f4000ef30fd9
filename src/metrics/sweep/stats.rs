//! What a sweep's episodes add up to: the paper's performance and grounding statistics (over
//! the steps of an episode, then its episodes, then mean ± std over evaluation seeds) and the
//! expert's agreement.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::EpisodeSummary;
use crate::metrics::grounding::WordKind;

pub use crate::stats::MeanStd;

fn mean(xs: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = xs.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// Task performance of a cell: over episodes per seed, then mean ± std over seeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Performance {
    /// Mean reward.
    pub reward: MeanStd,
    /// Success rate.
    pub success: MeanStd,
    /// Mean episode length.
    pub length: MeanStd,
    /// Mean reward of the successful episodes.
    pub reward_given_success: MeanStd,
}

/// Grounding accuracies of one word kind in a cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroundingStats {
    /// `acc`.
    pub acc: MeanStd,
    /// `acc_ng`.
    pub acc_ng: MeanStd,
    /// `acc_bs`.
    pub acc_bs: MeanStd,
    /// `acc_cmb`.
    pub acc_cmb: MeanStd,
    /// The hit rate at each offset of [`super::grounding::AROUND`], averaged as the four
    /// accuracies are (`around[4]` is `acc`, `around[1]` is `acc_bs`).
    #[serde(default)]
    pub around: Vec<MeanStd>,
    /// The pointing game (the map's largest cell on a related object).
    #[serde(default)]
    pub pointing: MeanStd,
    /// Relevance mass (the map's mass on the related objects).
    #[serde(default)]
    pub mass: MeanStd,
    /// Chance: a uniform map's `acc`, `acc_ng`, `acc_bs`, `acc_cmb`, pointing game and mass
    /// on the same steps, averaged as the figures are ([`crate::metrics::grounding::Accuracies::ALL_NAMES`] order).
    #[serde(default)]
    pub chance: Vec<MeanStd>,
    /// Location words only: the map's mass in the half-plane the word names, and a uniform
    /// map's (nothing measured for the other classes).
    #[serde(default)]
    pub region: MeanStd,
    /// A uniform map's region mass on the same steps.
    #[serde(default)]
    pub region_chance: MeanStd,
    /// Evaluated steps over all episodes.
    pub evaluated_steps: u64,
    /// Episodes with no evaluated step (left out of the averages).
    pub episodes_without: u64,
}

impl GroundingStats {
    /// Chance's figure `i` ([`crate::metrics::grounding::Accuracies::ALL_NAMES`] order), mean
    /// over seeds.
    pub fn chance_mean(&self, i: usize) -> Option<f64> {
        self.chance.get(i).and_then(|m| m.mean)
    }

    /// [`Self::chance_mean`] as a CSV cell: six decimals, empty where not measured.
    pub fn chance_cell(&self, i: usize) -> String {
        self.chance_mean(i)
            .map_or_else(String::new, |v| format!("{v:.6}"))
    }
}

/// Splits summaries by evaluation seed, in seed order.
fn by_seed(eps: &[EpisodeSummary]) -> Vec<Vec<&EpisodeSummary>> {
    let mut m: BTreeMap<u64, Vec<&EpisodeSummary>> = BTreeMap::new();
    for e in eps {
        m.entry(e.eval_seed).or_default().push(e);
    }
    m.into_values().collect()
}

/// Task performance: per seed over its episodes, then mean ± std over seeds.
pub fn performance(eps: &[EpisodeSummary]) -> Performance {
    let seeds = by_seed(eps);
    let per = |f: &dyn Fn(&[&EpisodeSummary]) -> f64| {
        MeanStd::of(&seeds.iter().map(|s| f(s)).collect::<Vec<_>>())
    };
    Performance {
        reward: per(&|s| mean(s.iter().map(|e| e.reward))),
        success: per(&|s| mean(s.iter().map(|e| f64::from(u8::from(e.success))))),
        length: per(&|s| mean(s.iter().map(|e| f64::from(e.length)))),
        reward_given_success: per(&|s| mean(s.iter().filter(|e| e.success).map(|e| e.reward))),
    }
}

/// A cell's episodes beside minigrid's bot: per seed over its episodes, then mean ± std over
/// seeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExpertStats {
    /// Share of the steps (where the bot had an action) at which the agent took it.
    pub agreement: MeanStd,
    /// Failed episodes: the step at which the agent first left the bot's plan at a cost ([`crate::bot::divergence_matters`]).
    pub first_divergence: MeanStd,
    /// Successful episodes the bot also solves: the bot's steps alone / the agent's steps.
    pub path_efficiency: MeanStd,
    /// The bot's own success rate from the same starts.
    pub bot_success: MeanStd,
}

/// [`ExpertStats`] of a cell's episodes.
pub fn expert_stats(eps: &[EpisodeSummary]) -> ExpertStats {
    let seeds = by_seed(eps);
    let per = |f: &dyn Fn(&[&EpisodeSummary]) -> f64| {
        MeanStd::of(&seeds.iter().map(|s| f(s)).collect::<Vec<_>>())
    };
    let finite = |x: f64| x.is_finite();
    ExpertStats {
        agreement: per(&|s| {
            mean(
                s.iter()
                    .map(|e| e.expert.agreement())
                    .filter(|&x| finite(x)),
            )
        }),
        first_divergence: per(&|s| {
            mean(
                s.iter()
                    .filter(|e| !e.success)
                    .filter_map(|e| e.expert.first_divergence.map(f64::from)),
            )
        }),
        path_efficiency: per(&|s| {
            mean(
                s.iter()
                    .map(|e| e.expert.path_efficiency(e.success, e.length))
                    .filter(|&x| finite(x)),
            )
        }),
        bot_success: per(&|s| {
            mean(
                s.iter()
                    .map(|e| f64::from(u8::from(e.expert.bot_length.is_some()))),
            )
        }),
    }
}

/// The figures [`grounding`] averages per step: six, nine offsets, six of chance, the region
/// and its chance.
const COLUMNS: usize = 23;

/// Grounding accuracies of `kind`: per episode over its evaluated steps (already in the
/// summaries), then per seed over episodes that had any, then mean ± std over seeds.
pub fn grounding(eps: &[EpisodeSummary], kind: WordKind) -> GroundingStats {
    let seeds = by_seed(eps);
    // The six figures, the nine offsets, then chance's six figures.
    let per_seed: Vec<[f64; COLUMNS]> = seeds
        .iter()
        .map(|s| {
            let vals: Vec<[f64; COLUMNS]> = s
                .iter()
                .filter_map(|e| e.grounding.get(&kind))
                .map(|(a, _)| {
                    let (v, c) = (a.all_values(), a.chance);
                    let chance = [c.acc, c.acc_ng, c.acc_bs, c.acc_cmb, c.pointing, c.mass];
                    std::array::from_fn(|i| match i {
                        0..6 => v[i],
                        6..15 => a.around[i - 6],
                        15..21 => chance[i - 15],
                        21 => a.region.unwrap_or(f64::NAN),
                        _ => a.region_chance.unwrap_or(f64::NAN),
                    })
                })
                .collect();
            std::array::from_fn(|i| mean(vals.iter().map(|v| v[i])))
        })
        .collect();
    let col = |i: usize| MeanStd::of(&per_seed.iter().map(|v| v[i]).collect::<Vec<_>>());
    GroundingStats {
        acc: col(0),
        acc_ng: col(1),
        acc_bs: col(2),
        acc_cmb: col(3),
        pointing: col(4),
        mass: col(5),
        around: (6..15).map(col).collect(),
        chance: (15..21).map(col).collect(),
        region: col(21),
        region_chance: col(22),
        evaluated_steps: eps
            .iter()
            .filter_map(|e| e.grounding.get(&kind))
            .map(|(_, n)| u64::from(*n))
            .sum(),
        episodes_without: eps
            .iter()
            .filter(|e| !e.grounding.contains_key(&kind))
            .count() as u64,
    }
}
