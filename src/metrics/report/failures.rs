//! The worst episodes of a sweep ([`worst_episodes`]), each with what replays it.

use serde::{Deserialize, Serialize};

use super::size_and_objects;
use crate::env::level::LevelConfig;
use crate::metrics::failure::{Counterfactual, FailureClass};
use crate::metrics::grounding::WordKind;
use crate::metrics::sweep::EpisodeSummary;

/// One of the worst episodes, enough to replay it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Failure {
    /// Why it is listed: `failed` or `low_acc_cmb`.
    pub kind: String,
    /// Checkpoint name.
    pub checkpoint: String,
    /// Room size (as its cell's: [`size_and_objects`]).
    pub size: usize,
    /// Object count (0 on a BabyAI level, as its cell's).
    pub objects: usize,
    /// Level seed (`groundscope replay --seed`).
    pub seed: u64,
    /// Mission.
    pub mission: String,
    /// Return.
    pub reward: f64,
    /// Length.
    pub length: u32,
    /// Episode acc_cmb of `M` on the targets, when evaluated.
    pub acc_cmb: Option<f64>,
    /// The command that replays it.
    pub replay: String,
    /// Its failure class (`None` for a successful episode listed for its low acc_cmb).
    #[serde(default)]
    pub class: Option<FailureClass>,
    /// What the agent was doing (failed episodes that showed a behaviour only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub behaviour: Option<FailureClass>,
    /// Steps with a target in view (failed episodes only).
    #[serde(default)]
    pub target_visible_steps: Option<u32>,
    /// Of those, steps with `M` on a target (failed episodes of attention models only).
    #[serde(default)]
    pub m_on_target_steps: Option<u32>,
    /// The same seed re-run without the non-target objects (failed episodes only; filled in
    /// by the caller, which holds the networks).
    #[serde(default)]
    pub counterfactual: Option<Counterfactual>,
    /// Why the re-run without distractors could not be built, where it could not (the
    /// episode keeps its row; the sweep goes on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub counterfactual_skipped: Option<String>,
    /// The registered BabyAI level (absent: the paper's level of `size` and `objects`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<String>,
    /// Whether the episode ran in the done-action mode (absent in older files: the model's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub done_required: Option<bool>,
    /// The step a failed episode opens at ([`crate::metrics::failure::decisive_step`]; absent
    /// in older files and for successes: the last step, or the first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decisive_step: Option<u32>,
}

impl Failure {
    /// The level the episode ran on, for a model trained on `base`.
    pub fn level_config(&self, base: LevelConfig) -> Result<LevelConfig, crate::env::EnvError> {
        let base = LevelConfig {
            done_required: self.done_required.unwrap_or(base.done_required),
            ..base
        };
        Ok(match &self.level {
            Some(id) => LevelConfig {
                babyai: Some(crate::env::level::LevelId::parse(id)?),
                ..base
            },
            None => LevelConfig {
                room_size: self.size,
                n_objects: self.objects,
                babyai: None,
                ..base
            },
        })
    }
}

impl Failure {
    /// The `groundscope view` command that opens the episode in the debugger: at its
    /// decisive step for a failed episode (where it was lost: [`Self::decisive_step`], else
    /// its last step, the debugger's "failure" step). For a
    /// Python policy's episode, the Rerun viewer on the recording its replay call writes.
    pub fn view_command(&self) -> String {
        if !self.replay.starts_with("groundscope replay") {
            // A Python policy's episode is replayed by a Python call that writes a recording
            // (`groundscope.record(act, …, "FILE.rrd")`): it opens in the Rerun viewer.
            return self
                .replay
                .rsplit('"')
                .find(|s| {
                    std::path::Path::new(s)
                        .extension()
                        .is_some_and(|e| e.eq_ignore_ascii_case("rrd"))
                })
                .map_or_else(String::new, |file| format!("rerun {file}"));
        }
        let view = self
            .replay
            .replacen("groundscope replay", "groundscope view", 1);
        if self.kind == "failed" && self.length > 0 {
            format!("{view} --step {}", self.opening_step())
        } else {
            view
        }
    }

    /// The step the debugger and the episode's page open at: a failed episode's decisive
    /// step ([`Self::decisive_step`], else its last step), 0 for a success listed for its
    /// low `acc_cmb`.
    pub fn opening_step(&self) -> u32 {
        if self.kind == "failed" && self.length > 0 {
            self.decisive_step.unwrap_or(self.length - 1)
        } else {
            0
        }
    }
}

/// The episode `acc_cmb` of `M` under which an episode is listed for it (`low_acc_cmb`): `M`
/// passed τ on its target at fewer than half the steps a target was in view. An episode at or
/// above it is not among the worst, however few episodes are under it (GoToDoor's ten
/// successes at 1.000 were once its "worst").
pub const LOW_ACC_CMB: f64 = 0.5;

/// Picks the K worst episodes of each kind: failures (longest first) and, among the episodes
/// whose acc_cmb of `M` on visible targets is under [`LOW_ACC_CMB`], the lowest.
pub fn worst_episodes(
    all: &[(String, LevelConfig, Vec<EpisodeSummary>)],
    k: usize,
    replay_args: &dyn Fn(&str, &LevelConfig, u64) -> String,
) -> Vec<Failure> {
    let mut failed = Vec::new();
    let mut low = Vec::new();
    for (ckpt, level, eps) in all {
        let (size, objects) = size_and_objects(level);
        let level_id = level.babyai.map(|id| id.id().to_owned());
        for e in eps {
            let acc_cmb = e.grounding.get(&WordKind::Combined).map(|(a, _)| a.acc_cmb);
            let f = |kind: &str| Failure {
                kind: kind.to_owned(),
                checkpoint: ckpt.clone(),
                size,
                objects,
                seed: e.level_seed,
                mission: e.mission.clone(),
                reward: e.reward,
                length: e.length,
                acc_cmb,
                replay: replay_args(ckpt, level, e.level_seed),
                level: level_id.clone(),
                done_required: Some(level.done_required),
                class: e.failure.map(|d| d.class),
                behaviour: e.failure.and_then(|d| d.behaviour),
                target_visible_steps: e.failure.map(|d| d.target_visible_steps),
                m_on_target_steps: e.failure.and_then(|d| d.m_on_target_steps),
                counterfactual: None,
                counterfactual_skipped: None,
                decisive_step: e.failure.map(|d| {
                    crate::metrics::failure::decisive_step(
                        d.lost_at,
                        e.expert.first_divergence,
                        e.length,
                    )
                }),
            };
            if !e.success {
                failed.push(f("failed"));
            }
            if acc_cmb.is_some_and(|a| a < LOW_ACC_CMB) {
                low.push(f("low_acc_cmb"));
            }
        }
    }
    failed.sort_by(|a, b| b.length.cmp(&a.length).then(a.seed.cmp(&b.seed)));
    low.sort_by(|a, b| {
        a.acc_cmb
            .partial_cmp(&b.acc_cmb)
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(a.seed.cmp(&b.seed))
    });
    let mut out = per_level(failed, k);
    // A level whose lowest acc_cmb are all 0 (a diffuse `M` passes τ nowhere) would list K
    // episodes in seed order, chosen by nothing: its list is left out.
    let low = per_level(low, k);
    let all_zero = |level: &Option<String>| {
        low.iter()
            .filter(|f| &f.level == level)
            .all(|f| f.acc_cmb == Some(0.0))
    };
    out.extend(low.iter().filter(|f| !all_zero(&f.level)).cloned());
    out
}

/// The first `k` of `sorted` for each BabyAI level, in order of each level's first entry
/// (the paper's cells, level `None`, count as one: its worst episodes across sizes as before).
fn per_level(sorted: Vec<Failure>, k: usize) -> Vec<Failure> {
    let mut taken: Vec<(Option<String>, usize)> = Vec::new();
    let mut kept = Vec::new();
    for f in sorted {
        let group = if let Some(i) = taken.iter().position(|(l, _)| *l == f.level) {
            i
        } else {
            taken.push((f.level.clone(), 0));
            taken.len() - 1
        };
        if taken[group].1 < k {
            taken[group].1 += 1;
            kept.push(f);
        }
    }
    // Grouped by level, the groups in order of their worst entry.
    let order: Vec<Option<String>> = taken.into_iter().map(|(l, _)| l).collect();
    kept.sort_by_key(|f| order.iter().position(|l| *l == f.level));
    kept
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::metrics::grounding::Accuracies;

    fn episode(seed: u64, acc_cmb: f64) -> EpisodeSummary {
        let mut grounding = BTreeMap::new();
        grounding.insert(
            WordKind::Combined,
            (
                Accuracies {
                    acc_cmb,
                    ..Accuracies::default()
                },
                3,
            ),
        );
        EpisodeSummary {
            eval_seed: 0,
            level_seed: seed,
            mission: "go to the red ball".into(),
            success: true,
            reward: 0.9,
            length: 5,
            grounding,
            failure: None,
            actions: Vec::new(),
            expert: crate::metrics::sweep::EpisodeExpert::default(),
        }
    }

    /// The low-acc_cmb list is a ranking: one of nothing but zeros says nothing and is left
    /// out; a list with something above zero keeps its zeros.
    #[test]
    fn a_low_acc_cmb_list_of_zeros_is_left_out() {
        let level = LevelConfig::default();
        let replay = |_: &str, _: &LevelConfig, s: u64| format!("groundscope replay --seed {s}");
        let zeros = vec![(
            "m".to_owned(),
            level,
            (0..5).map(|s| episode(s, 0.0)).collect(),
        )];
        assert!(worst_episodes(&zeros, 3, &replay).is_empty());
        let some = vec![(
            "m".to_owned(),
            level,
            vec![episode(0, 0.0), episode(1, 0.25), episode(2, 0.0)],
        )];
        let listed = worst_episodes(&some, 3, &replay);
        assert_eq!(listed.iter().map(|f| f.seed).collect::<Vec<_>>(), [0, 2, 1]);
    }

    /// Only episodes under the threshold are "worst": perfect ones never, however few
    /// episodes fall under it; failures are listed whatever their acc_cmb.
    #[test]
    fn only_episodes_under_the_threshold_are_listed_for_their_acc_cmb() {
        let level = LevelConfig::default();
        let replay = |_: &str, _: &LevelConfig, s: u64| format!("groundscope replay --seed {s}");
        let perfect = vec![(
            "m".to_owned(),
            level,
            (0..10).map(|s| episode(s, 1.0)).collect(),
        )];
        assert!(worst_episodes(&perfect, 10, &replay).is_empty());
        let mut failed = episode(7, 1.0);
        failed.success = false;
        let mixed = vec![(
            "m".to_owned(),
            level,
            vec![
                episode(0, 1.0),
                episode(1, LOW_ACC_CMB),
                episode(2, 0.4),
                episode(3, 0.9),
                failed,
            ],
        )];
        let listed = worst_episodes(&mixed, 10, &replay);
        let seen: Vec<(&str, u64)> = listed.iter().map(|f| (f.kind.as_str(), f.seed)).collect();
        assert_eq!(seen, [("failed", 7), ("low_acc_cmb", 2)]);
        assert!(
            listed
                .iter()
                .filter(|f| f.kind == "low_acc_cmb")
                .all(|f| f.acc_cmb.is_some_and(|a| a < LOW_ACC_CMB))
        );
    }
}
