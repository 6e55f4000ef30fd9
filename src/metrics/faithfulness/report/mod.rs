//! Aggregation of episode results into `faithfulness.json` (schema in
//! docs/formats.md#faithfulness-reports), with a Markdown table and a per-step CSV. Every
//! value is paired with its control.

mod text;
pub mod verdict;

pub use text::{FIGURES, steps_csv};

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::episode::{CLOSED_LOOP, COUNTERFACTUALS, Counterfactual, EpisodeResult, Rollout};
use super::step::{CURVE_POINTS, Curves, INTERVENTIONS, StepResult};
use crate::metrics::grounding::WordKind;
use crate::metrics::sweep::MeanStd;

/// Version of `faithfulness.json`.
pub const SCHEMA_VERSION: u32 = 1;

/// The report's file in `faithfulness --out DIR`.
pub const REPORT_FILE: &str = "faithfulness.json";

/// Bins of the rank-correlation histogram over [−1, 1].
pub const RHO_BINS: usize = 20;

/// A measure beside its control.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Paired {
    /// The measure.
    pub value: MeanStd,
    /// Its control or chance level.
    pub control: MeanStd,
    /// What the control is (not read back from a file: empty there).
    #[serde(skip_deserializing)]
    pub control_is: &'static str,
}

/// Occlusion results.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Occlusion {
    /// Spearman ρ(M, Δ) over the 49 cells; control: a randomly permuted M.
    pub rank_correlation: Option<Paired>,
    /// Analysed steps where M or Δ was constant (left out of ρ).
    pub constant_steps: usize,
    /// argmax M = argmax Δ; control: permuted M.
    pub argmax_agreement: Option<Paired>,
    /// With ≥ 2 objects in view: the object with the largest M is the one whose occlusion
    /// changes the action distribution most; control: permuted M.
    pub object_agreement: Option<Paired>,
    /// The chance of picking that object at random (1 / objects in view).
    pub object_random_pick: MeanStd,
    /// With the target and ≥ 1 other object in view: occluding the target changes the
    /// action distribution most (attention-free; the baseline has it too).
    pub target_most_effective: Paired,
}

/// Normalised AUCs of deletion or insertion, and the mean curves for the figure.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Aucs {
    /// Objects in decreasing-M order (attention model).
    pub by_m: Option<MeanStd>,
    /// Random orders (the control).
    pub random: MeanStd,
    /// Decreasing-Δ order (the oracle).
    pub oracle: MeanStd,
    /// Mean curves over all analysed steps, [`CURVE_POINTS`] points from 0 to 1 of the
    /// objects removed (or inserted), relative to the unperturbed probability.
    pub curves: BTreeMap<&'static str, Vec<f64>>,
}

/// A one-step intervention on M.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct InterventionEffect {
    /// Total-variation distance of the action distributions.
    pub tv: MeanStd,
    /// Rate at which the most probable action changes.
    pub flip_rate: MeanStd,
    /// Steps where it was possible.
    pub steps: usize,
}

/// A closed-loop re-run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClosedLoop {
    /// Success rate.
    pub success: MeanStd,
    /// Rate of episodes that picked up or declared done at an object the mission does not
    /// name.
    pub distractor: MeanStd,
    /// Episodes run.
    pub episodes: usize,
}

/// One counterfactual edit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CounterfactualEffect {
    /// Episodes whose world could be edited.
    pub ran: usize,
    /// Episodes skipped, by reason.
    pub skipped: BTreeMap<String, usize>,
    /// Steps with the named object in view where argmax M is on it: edited vs unedited.
    pub tracking: Paired,
    /// Success on the edited task vs the unedited one (same episodes).
    pub success: Paired,
}

/// Localisation of one word kind's map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LocalisationStats {
    /// argmax of the map on a related object; chance: a uniform map.
    pub pointing_game: Paired,
    /// Σ of the map over related cells.
    pub relevance_mass: Paired,
    /// Fraction of the top-n cells that are related (n = related cells).
    pub rank_accuracy: Paired,
}

/// Everything measured for one checkpoint.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CheckpointFaithfulness {
    /// The checkpoint.
    pub checkpoint: String,
    /// attention or baseline.
    pub variant: String,
    /// The level (set by the caller).
    pub level: String,
    /// Episodes analysed.
    pub episodes: usize,
    /// Steps analysed (at least one object in view).
    pub analysed_steps: usize,
    /// Success of the unperturbed episodes.
    pub success: MeanStd,
    /// Occlusion.
    pub occlusion: Occlusion,
    /// Deletion (objects removed one by one).
    pub deletion: Aucs,
    /// Insertion (objects put back into an emptied view).
    pub insertion: Aucs,
    /// One-step interventions on M by name.
    pub interventions: BTreeMap<&'static str, InterventionEffect>,
    /// Closed-loop re-runs by intervention.
    pub closed_loop: BTreeMap<&'static str, ClosedLoop>,
    /// Counterfactual edits.
    pub counterfactuals: BTreeMap<&'static str, CounterfactualEffect>,
    /// Localisation per word kind.
    pub localisation: BTreeMap<WordKind, LocalisationStats>,
    /// Histogram of per-step ρ over [−1, 1] ([`RHO_BINS`] bins): measured and permuted.
    pub rho_histogram: BTreeMap<&'static str, Vec<usize>>,
}

/// The whole report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FaithfulnessReport {
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// The level.
    pub level: String,
    /// Evaluation seeds.
    pub seeds: u64,
    /// The first evaluation seed (`--first-seed`); written only when not 0, so reports of
    /// the standard seeds are as before.
    #[serde(skip_serializing_if = "is_zero")]
    pub first_seed: u64,
    /// Episodes per seed.
    pub episodes_per_seed: u64,
    /// greedy or sampled.
    pub actions: &'static str,
    /// Wall time in seconds.
    pub seconds: f64,
    /// One entry per checkpoint.
    pub checkpoints: Vec<CheckpointFaithfulness>,
}

/// What `study collect` reads back of a `faithfulness.json`: each checkpoint's level, closed
/// loops and localisation, in the report's own types under its own field names. [`Self::of`]
/// builds it from a [`FaithfulnessReport`], so that a field renamed there fails to compile
/// here, and this module's tests read a written report back through it.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct FaithfulnessFigures {
    /// [`FaithfulnessReport::checkpoints`].
    pub checkpoints: Vec<CheckpointFigures>,
}

/// One checkpoint of [`FaithfulnessFigures`].
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct CheckpointFigures {
    /// [`CheckpointFaithfulness::level`].
    pub level: String,
    /// [`CheckpointFaithfulness::closed_loop`].
    pub closed_loop: BTreeMap<String, ClosedLoop>,
    /// [`CheckpointFaithfulness::localisation`].
    pub localisation: BTreeMap<WordKind, LocalisationStats>,
}

impl FaithfulnessFigures {
    /// The figures of `report` as its file reads back (a [`Paired`]'s `control_is` is not
    /// read back).
    pub fn of(report: &FaithfulnessReport) -> Self {
        let checkpoints = report
            .checkpoints
            .iter()
            .map(|c| CheckpointFigures {
                level: c.level.clone(),
                closed_loop: c
                    .closed_loop
                    .iter()
                    .map(|(name, l)| ((*name).to_owned(), l.clone()))
                    .collect(),
                localisation: c
                    .localisation
                    .iter()
                    .map(|(kind, l)| {
                        let mut l = l.clone();
                        l.pointing_game.control_is = "";
                        l.relevance_mass.control_is = "";
                        l.rank_accuracy.control_is = "";
                        (*kind, l)
                    })
                    .collect(),
            })
            .collect();
        Self { checkpoints }
    }
}

#[expect(
    clippy::trivially_copy_pass_by_ref,
    reason = "serde's skip_serializing_if passes a reference"
)]
fn is_zero(x: &u64) -> bool {
    *x == 0
}

/// Mean ± std over seeds of per-seed means of per-episode means of `f`'s values (an episode
/// without values does not count; nor does a seed without episodes).
fn agg(eps: &[EpisodeResult], f: impl Fn(&EpisodeResult) -> Vec<f64>) -> MeanStd {
    let mut per_seed: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for e in eps {
        let v: Vec<f64> = f(e).into_iter().filter(|x| x.is_finite()).collect();
        if !v.is_empty() {
            per_seed
                .entry(e.eval_seed)
                .or_default()
                .push(v.iter().sum::<f64>() / v.len() as f64);
        }
    }
    let means: Vec<f64> = per_seed
        .values()
        .map(|v| v.iter().sum::<f64>() / v.len() as f64)
        .collect();
    MeanStd::of(&means)
}

fn steps_agg(eps: &[EpisodeResult], f: impl Fn(&StepResult) -> Option<f64>) -> MeanStd {
    agg(eps, |e| e.steps.iter().filter_map(&f).collect())
}

fn flag(b: bool) -> f64 {
    f64::from(u8::from(b))
}

fn paired(
    eps: &[EpisodeResult],
    value: impl Fn(&StepResult) -> Option<f64>,
    control: impl Fn(&StepResult) -> Option<f64>,
    control_is: &'static str,
) -> Paired {
    Paired {
        value: steps_agg(eps, value),
        control: steps_agg(eps, control),
        control_is,
    }
}

fn some_if(measured: bool, p: Paired) -> Option<Paired> {
    measured.then_some(p)
}

/// One of the three curves of a [`Curves`].
type CurveOf = fn(&Curves) -> &Option<(Vec<f64>, f64)>;

fn aucs(eps: &[EpisodeResult], pick: impl Fn(&StepResult) -> &Curves) -> Aucs {
    let auc = |which: CurveOf| steps_agg(eps, |s| which(pick(s)).as_ref().map(|c| c.1));
    let mut curves = BTreeMap::new();
    let kinds: [(&'static str, CurveOf); 3] = [
        ("by_m", |c| &c.by_m),
        ("random", |c| &c.random),
        ("oracle", |c| &c.oracle),
    ];
    for (name, which) in kinds {
        let all: Vec<&Vec<f64>> = eps
            .iter()
            .flat_map(|e| &e.steps)
            .filter_map(|s| which(pick(s)).as_ref().map(|c| &c.0))
            .collect();
        if !all.is_empty() {
            let mean = (0..CURVE_POINTS)
                .map(|i| all.iter().map(|c| c[i]).sum::<f64>() / all.len() as f64)
                .collect();
            curves.insert(name, mean);
        }
    }
    let any_m = eps
        .iter()
        .flat_map(|e| &e.steps)
        .any(|s| pick(s).by_m.is_some());
    Aucs {
        by_m: any_m.then(|| auc(|c| &c.by_m)),
        random: auc(|c| &c.random),
        oracle: auc(|c| &c.oracle),
        curves,
    }
}

fn histogram(values: impl Iterator<Item = f64>) -> Vec<usize> {
    let mut bins = vec![0; RHO_BINS];
    for v in values {
        let b = (f64::midpoint(v, 1.0) * RHO_BINS as f64).floor() as isize;
        bins[b.clamp(0, RHO_BINS as isize - 1) as usize] += 1;
    }
    bins
}

fn rollout_rate(r: Option<&Rollout>, f: impl Fn(&Rollout) -> f64) -> Vec<f64> {
    r.map(f).into_iter().collect()
}

fn tracking(r: &Rollout) -> f64 {
    if r.target_visible_steps == 0 {
        f64::NAN
    } else {
        f64::from(r.tracking_steps) / f64::from(r.target_visible_steps)
    }
}

/// Aggregates the episodes of one checkpoint.
pub fn summarise(checkpoint: &str, variant: &str, eps: &[EpisodeResult]) -> CheckpointFaithfulness {
    let steps: Vec<&StepResult> = eps.iter().flat_map(|e| &e.steps).collect();
    let attention = variant == "attention";
    let has = |f: &dyn Fn(&StepResult) -> bool| steps.iter().any(|s| f(s));
    let occlusion = Occlusion {
        rank_correlation: some_if(
            attention,
            paired(
                eps,
                |s| s.rank_correlation,
                |s| s.chance_rank_correlation,
                "permuted M",
            ),
        ),
        constant_steps: if attention {
            steps
                .iter()
                .filter(|s| s.rank_correlation.is_none())
                .count()
        } else {
            0
        },
        argmax_agreement: some_if(
            attention,
            paired(
                eps,
                |s| s.argmax_agreement.map(flag),
                |s| s.chance_argmax_agreement.map(flag),
                "permuted M",
            ),
        ),
        object_agreement: some_if(
            attention,
            paired(
                eps,
                |s| s.object_agreement.map(flag),
                |s| s.chance_object_agreement.map(flag),
                "permuted M",
            ),
        ),
        object_random_pick: steps_agg(eps, |s| s.random_pick),
        target_most_effective: paired(
            eps,
            |s| s.target_most_effective.map(flag),
            |s| s.target_most_effective.and(s.random_pick),
            "a random object in view",
        ),
    };
    let mut interventions = BTreeMap::new();
    for name in INTERVENTIONS {
        if has(&|s| s.interventions.contains_key(name)) {
            interventions.insert(
                name,
                InterventionEffect {
                    tv: steps_agg(eps, |s| s.interventions.get(name).map(|e| e.tv)),
                    flip_rate: steps_agg(eps, |s| s.interventions.get(name).map(|e| flag(e.flip))),
                    steps: steps
                        .iter()
                        .filter(|s| s.interventions.contains_key(name))
                        .count(),
                },
            );
        }
    }
    let mut closed_loop = BTreeMap::new();
    for name in CLOSED_LOOP {
        let n = eps
            .iter()
            .filter(|e| e.closed_loop.contains_key(name))
            .count();
        if n > 0 {
            closed_loop.insert(
                name,
                ClosedLoop {
                    success: agg(eps, |e| {
                        rollout_rate(e.closed_loop.get(name), |r| flag(r.success))
                    }),
                    distractor: agg(eps, |e| {
                        rollout_rate(e.closed_loop.get(name), |r| flag(r.distractor))
                    }),
                    episodes: n,
                },
            );
        }
    }
    let mut counterfactuals = BTreeMap::new();
    for name in COUNTERFACTUALS {
        let ran = |e: &EpisodeResult| match e.counterfactuals.get(name) {
            Some(Counterfactual::Ran(r)) => Some(*r),
            _ => None,
        };
        let n_ran = eps.iter().filter(|e| ran(e).is_some()).count();
        let mut skipped = BTreeMap::new();
        for e in eps {
            if let Some(Counterfactual::Skipped(why)) = e.counterfactuals.get(name) {
                *skipped.entry(why.clone()).or_default() += 1;
            }
        }
        if n_ran + skipped.values().sum::<usize>() == 0 {
            continue;
        }
        // Controls are the same episodes unedited.
        counterfactuals.insert(
            name,
            CounterfactualEffect {
                ran: n_ran,
                skipped,
                // Tracking needs `M`: not measured (null) for a model without maps.
                tracking: Paired {
                    value: agg(eps, |e| {
                        ran(e)
                            .filter(|_| attention)
                            .map(|r| tracking(&r))
                            .into_iter()
                            .collect()
                    }),
                    control: agg(eps, |e| {
                        ran(e)
                            .filter(|_| attention)
                            .map(|_| tracking(&e.rollout))
                            .into_iter()
                            .collect()
                    }),
                    control_is: "the same episodes unedited",
                },
                success: Paired {
                    value: agg(eps, |e| {
                        ran(e).map(|r| flag(r.success)).into_iter().collect()
                    }),
                    control: agg(eps, |e| {
                        ran(e)
                            .map(|_| flag(e.rollout.success))
                            .into_iter()
                            .collect()
                    }),
                    control_is: "the same episodes unedited",
                },
            },
        );
    }
    let mut localisation = BTreeMap::new();
    for kind in WordKind::ALL {
        if !has(&|s| s.localisation.contains_key(&kind)) {
            continue;
        }
        let l = |f: fn(&super::measures::Localisation) -> f64| {
            move |s: &StepResult| s.localisation.get(&kind).map(f)
        };
        let chance = l(|x| x.chance);
        localisation.insert(
            kind,
            LocalisationStats {
                pointing_game: paired(eps, l(|x| x.pointing_game), chance, "a uniform map"),
                relevance_mass: paired(eps, l(|x| x.relevance_mass), chance, "a uniform map"),
                rank_accuracy: paired(eps, l(|x| x.rank_accuracy), chance, "a uniform map"),
            },
        );
    }
    let mut rho_histogram = BTreeMap::new();
    if attention {
        rho_histogram.insert(
            "measured",
            histogram(steps.iter().filter_map(|s| s.rank_correlation)),
        );
        rho_histogram.insert(
            "permuted",
            histogram(steps.iter().filter_map(|s| s.chance_rank_correlation)),
        );
    }
    CheckpointFaithfulness {
        checkpoint: checkpoint.to_owned(),
        variant: variant.to_owned(),
        level: String::new(),
        episodes: eps.len(),
        analysed_steps: steps.len(),
        success: agg(eps, |e| vec![flag(e.rollout.success)]),
        occlusion,
        deletion: aucs(eps, |s| &s.deletion),
        insertion: aucs(eps, |s| &s.insertion),
        interventions,
        closed_loop,
        counterfactuals,
        localisation,
        rho_histogram,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `faithfulness.json` as the command writes it reads back as the figures `study collect`
    /// takes from it.
    #[test]
    fn a_written_report_reads_back_as_its_figures() {
        let mut c = summarise("bundled:attention", "attention", &[]);
        c.level = "S8N4 goto".into();
        let m = |x: f64| MeanStd {
            mean: Some(x),
            std: Some(0.0),
        };
        c.closed_loop.insert(
            CLOSED_LOOP[0],
            ClosedLoop {
                success: m(0.75),
                distractor: m(0.125),
                episodes: 8,
            },
        );
        let paired = |x: f64| Paired {
            value: m(x),
            control: m(0.25),
            control_is: "a uniform map",
        };
        c.localisation.insert(
            WordKind::Combined,
            LocalisationStats {
                pointing_game: paired(0.5),
                relevance_mass: paired(0.375),
                rank_accuracy: paired(0.625),
            },
        );
        let report = FaithfulnessReport {
            schema_version: SCHEMA_VERSION,
            level: c.level.clone(),
            seeds: 1,
            first_seed: 0,
            episodes_per_seed: 8,
            actions: "greedy",
            seconds: 1.0,
            checkpoints: vec![c],
        };
        let json = serde_json::to_string_pretty(&report).unwrap();
        let read: FaithfulnessFigures = serde_json::from_str(&json).unwrap();
        assert_eq!(read, FaithfulnessFigures::of(&report));
        let c = &read.checkpoints[0];
        assert_eq!(c.closed_loop["none"].success.mean, Some(0.75));
        assert_eq!(
            c.localisation[&WordKind::Combined].pointing_game.value.mean,
            Some(0.5)
        );
    }
}
