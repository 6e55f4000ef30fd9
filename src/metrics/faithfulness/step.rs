//! One step under the microscope: occlusion, deletion/insertion, one-step interventions on
//! `M` and localisation, all with the LSTM memory of the unperturbed rollout held fixed.
//! Each perturbation family is one batched forward.

use std::collections::BTreeMap;

use candle_core::{Device, Tensor};
use rand::seq::SliceRandom as _;
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use super::measures::{
    Localisation, argmax, flat, localisation, normalised_auc, rank_correlation, resample,
    total_variation,
};
use crate::env::targets::{WordTargets, visible_objects};
use crate::env::view::{AGENT_IN_VIEW, Observation, VIEW_SIZE, ViewCell};
use crate::metrics::grounding::WordKind;
use crate::policy::obs::N_CELLS;
use crate::policy::{Acting, AttentionTrace, Intervention, Memory, PolicyError, Step};

/// What an occluded cell becomes: empty floor, `(1, 0, 0)`.
pub const EMPTY_FLOOR: [u8; 3] = [1, 0, 0];

/// Random deletion orders averaged per step.
pub const RANDOM_ORDERS: usize = 4;

/// Points at which deletion and insertion curves are resampled for averaging.
pub const CURVE_POINTS: usize = 11;

/// The names of the one-step interventions, in report order.
pub const INTERVENTIONS: [&str; 3] = ["uniform", "permuted", "steered"];

/// The flat index of a view cell (`j = vy·7 + vx`, as the maps).
pub fn cell_index((vx, vy): ViewCell) -> usize {
    vy * VIEW_SIZE + vx
}

/// The view cell of a flat index.
pub fn index_cell(j: usize) -> ViewCell {
    (j % VIEW_SIZE, j / VIEW_SIZE)
}

/// Everything about one step the perturbations start from.
pub struct StepInput<'a> {
    /// The policy: a native network or an imported graph.
    pub agent: &'a (dyn Acting + Sync),
    /// The agent's direction (0–3), for a graph that reads it.
    pub direction: u8,
    /// The mission's tokens.
    pub tokens: &'a [u32],
    /// The memory before this step, (1, H), from the unperturbed rollout.
    pub memory: &'a Memory,
    /// The observation.
    pub obs: Observation,
    /// What each scored word of the mission names in view at this step
    /// ([`crate::env::targets::word_targets`]): the cells its map is localised on.
    pub words: Vec<WordTargets>,
    /// `M`'s targets in view: the objects the clauses the verifier waits on matched
    /// ([`crate::metrics::grounding::pending_targets`]).
    pub targets: Vec<ViewCell>,
    /// Unperturbed action probabilities.
    pub probs: &'a [f32],
    /// The action taken.
    pub action: usize,
    /// Unperturbed attention (attention model only).
    pub attention: Option<&'a AttentionTrace>,
}

/// The effect of one intervention on the action distribution.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Effect {
    /// Total-variation distance to the unperturbed distribution.
    pub tv: f64,
    /// Whether the most probable action changed.
    pub flip: bool,
}

/// Deletion or insertion curves of one step, resampled to [`CURVE_POINTS`], each divided
/// by the unperturbed probability of the chosen action; and their normalised AUCs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Curves {
    /// Objects in decreasing-`M` order (attention model only).
    pub by_m: Option<(Vec<f64>, f64)>,
    /// Random orders, averaged.
    pub random: Option<(Vec<f64>, f64)>,
    /// Decreasing-Δ order (the oracle of single-object effects).
    pub oracle: Option<(Vec<f64>, f64)>,
}

/// Results of one analysed step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepResult {
    /// Δ of every view cell (0 for cells not occluded), agent-up.
    pub occlusion: Vec<f64>,
    /// Spearman ρ of `M` and Δ; `None` when either is constant.
    pub rank_correlation: Option<f64>,
    /// The same for a randomly permuted `M` (the chance control).
    pub chance_rank_correlation: Option<f64>,
    /// argmax M = argmax Δ (steps with a non-constant Δ).
    pub argmax_agreement: Option<bool>,
    /// The same for the permuted `M`.
    pub chance_argmax_agreement: Option<bool>,
    /// With two or more visible objects: the object with the largest `M` is the one whose
    /// occlusion changes the action distribution most.
    pub object_agreement: Option<bool>,
    /// The same for the permuted `M`.
    pub chance_object_agreement: Option<bool>,
    /// The chance of a random pick: 1 / visible objects.
    pub random_pick: Option<f64>,
    /// With the target visible: removing it changes the distribution most of all objects
    /// (defined for the baseline too).
    pub target_most_effective: Option<bool>,
    /// Deletion curves.
    pub deletion: Curves,
    /// Insertion curves (objects put back into a view emptied of them).
    pub insertion: Curves,
    /// One-step interventions on `M` by name ([`INTERVENTIONS`]); missing where impossible.
    pub interventions: BTreeMap<&'static str, Effect>,
    /// Localisation of the object word's map, the colour word's map and `M`.
    pub localisation: BTreeMap<WordKind, Localisation>,
}

/// The same memory for `b` rows.
fn repeat(memory: &Memory, b: usize) -> Result<Memory, PolicyError> {
    Ok(Memory {
        h: memory.h.repeat((b, 1))?,
        c: memory.c.repeat((b, 1))?,
    })
}

/// Action probabilities of a batch of observations of this step (one forward).
fn forward(
    input: &StepInput<'_>,
    obs: &[Observation],
    intervention: Option<&Intervention>,
) -> Result<Vec<Vec<f32>>, PolicyError> {
    probs_of(
        input.agent,
        obs,
        input.direction,
        input.tokens,
        input.memory,
        intervention,
    )
}

/// Action probabilities of `obs`, every row one view of the same step: the same direction,
/// mission and memory (1 row, repeated), one batched forward.
fn probs_of<P: Acting + ?Sized>(
    agent: &P,
    obs: &[Observation],
    direction: u8,
    tokens: &[u32],
    memory: &Memory,
    intervention: Option<&Intervention>,
) -> Result<Vec<Vec<f32>>, PolicyError> {
    if obs.is_empty() {
        return Ok(Vec::new());
    }
    let n = obs.len();
    let memory = repeat(memory, n)?;
    Ok(agent
        .act_step(&Step {
            obs,
            directions: &vec![direction; n],
            missions: &vec![tokens; n],
            // Every row is the same episode's step, perturbed.
            rows: &vec![0; n],
            prepared: None,
            memory: &memory,
            traces: false,
            intervention,
        })?
        .probs)
}

fn with_cells(
    obs: &Observation,
    cells: &[ViewCell],
    value: impl Fn(ViewCell) -> [u8; 3],
) -> Observation {
    let mut o = *obs;
    for &c in cells {
        o.image[c.0][c.1] = value(c);
    }
    o
}

/// Cells occlusion replaces: visible, not empty floor, not the agent's own cell.
pub fn occludable(obs: &Observation) -> Vec<ViewCell> {
    let mut out = Vec::new();
    for vy in 0..VIEW_SIZE {
        for vx in 0..VIEW_SIZE {
            let enc = obs.image[vx][vy];
            if (vx, vy) != AGENT_IN_VIEW && enc[0] != 0 && enc[0] != EMPTY_FLOOR[0] {
                out.push((vx, vy));
            }
        }
    }
    out
}

/// Δ of every cell: one forward over all occluded observations.
pub fn occlusion(input: &StepInput<'_>) -> Result<Vec<f64>, PolicyError> {
    occlusion_of(
        input.agent,
        &input.obs,
        input.direction,
        input.tokens,
        input.memory,
        input.probs,
    )
}

/// Occlusion saliency, the one definition: Δ of every view cell (agent-up `j = vy·7 + vx`),
/// the total-variation distance between `probs` (the unperturbed action distribution) and the
/// distribution when that cell alone is replaced by empty floor, from the same `memory`
/// (1 row); 0 for cells not [`occludable`]. One forward over all occluded observations. Any
/// policy: this is what stands in for the maps of a model that exports none.
pub fn occlusion_of<P: Acting + ?Sized>(
    agent: &P,
    obs: &Observation,
    direction: u8,
    tokens: &[u32],
    memory: &Memory,
    probs: &[f32],
) -> Result<Vec<f64>, PolicyError> {
    let cells = occludable(obs);
    let batch: Vec<Observation> = cells
        .iter()
        .map(|&c| with_cells(obs, &[c], |_| EMPTY_FLOOR))
        .collect();
    let mut delta = vec![0.0; N_CELLS];
    for (c, p) in cells
        .iter()
        .zip(&probs_of(agent, &batch, direction, tokens, memory, None)?)
    {
        delta[cell_index(*c)] = total_variation(probs, p);
    }
    Ok(delta)
}

/// `M` steered onto a distractor: each target cell's mass moves to the nearest visible
/// non-target object (Chebyshev distance, then index order). `None` without a visible
/// target or distractor.
pub fn steered(m: &[f64], targets: &[ViewCell], objects: &[ViewCell]) -> Option<Vec<f64>> {
    let distractors: Vec<ViewCell> = objects
        .iter()
        .copied()
        .filter(|o| !targets.contains(o))
        .collect();
    if targets.is_empty() || distractors.is_empty() {
        return None;
    }
    let mut out = m.to_vec();
    for t in targets {
        let dist = |d: &ViewCell| t.0.abs_diff(d.0).max(t.1.abs_diff(d.1));
        let nearest = distractors
            .iter()
            .min_by_key(|d| (dist(d), cell_index(**d)))?;
        let mass = out[cell_index(*t)];
        out[cell_index(*t)] = 0.0;
        out[cell_index(*nearest)] += mass;
    }
    Some(out)
}

/// Probability of the chosen action along each order of `objects`: deletion removes them one
/// by one from the observation; insertion puts them back one by one into a view emptied of
/// all of them. One forward for every order of both.
/// Deletion and insertion curves, one per order.
type CurvePair = (Vec<Vec<f64>>, Vec<Vec<f64>>);

fn curves(
    input: &StepInput<'_>,
    objects: &[ViewCell],
    orders: &[Vec<ViewCell>],
) -> Result<CurvePair, PolicyError> {
    let empty = with_cells(&input.obs, objects, |_| EMPTY_FLOOR);
    let mut batch = Vec::new();
    for order in orders {
        for k in 0..=order.len() {
            batch.push(with_cells(&input.obs, &order[..k], |_| EMPTY_FLOOR));
        }
        for k in 0..=order.len() {
            batch.push(with_cells(&empty, &order[..k], |c| {
                input.obs.image[c.0][c.1]
            }));
        }
    }
    let probs = forward(input, &batch, None)?;
    let mut rows = probs.iter().map(|p| f64::from(p[input.action]));
    let (mut del, mut ins) = (Vec::new(), Vec::new());
    for order in orders {
        del.push(rows.by_ref().take(order.len() + 1).collect());
        ins.push(rows.by_ref().take(order.len() + 1).collect());
    }
    Ok((del, ins))
}

/// Objects in decreasing order of `score` at their cells (index order among equals).
fn ranked(objects: &[ViewCell], score: &[f64]) -> Vec<ViewCell> {
    let mut v = objects.to_vec();
    v.sort_by(|a, b| {
        score[cell_index(*b)]
            .total_cmp(&score[cell_index(*a)])
            .then(cell_index(*a).cmp(&cell_index(*b)))
    });
    v
}

fn summarise(curve: &[f64], reference: f64) -> Option<(Vec<f64>, f64)> {
    let auc = normalised_auc(curve, reference)?;
    let normalised: Vec<f64> = curve.iter().map(|p| p / reference).collect();
    Some((resample(&normalised, CURVE_POINTS), auc))
}

fn mean_of(curves: &[Vec<f64>]) -> Vec<f64> {
    let n = curves.len().max(1) as f64;
    let len = curves.first().map_or(0, Vec::len);
    (0..len)
        .map(|i| curves.iter().map(|c| c[i]).sum::<f64>() / n)
        .collect()
}

/// Analyses one step with at least one visible object. `rng` draws the permutation of the
/// chance control and the random deletion orders.
pub fn analyse(input: &StepInput<'_>, rng: &mut Pcg64Mcg) -> Result<StepResult, PolicyError> {
    let targets = input.targets.clone();
    let objects = candidate_objects(&input.obs, &targets);
    let delta = occlusion(input)?;
    let mut r = StepResult {
        random_pick: (objects.len() >= 2).then(|| 1.0 / objects.len() as f64),
        ..StepResult::default()
    };
    let delta_constant = delta.iter().all(|d| *d == delta[0]);
    let best_object = |score: &[f64]| ranked(&objects, score).first().copied();
    if !targets.is_empty() && objects.len() >= 2 {
        r.target_most_effective = best_object(&delta).map(|b| targets.contains(&b));
    }
    let m: Option<Vec<f64>> = input.attention.map(|a| flat(&a.combined));
    let mut permuted = None;
    if let Some(m) = &m {
        let mut perm: Vec<usize> = (0..N_CELLS).collect();
        perm.shuffle(rng);
        let mp: Vec<f64> = perm.iter().map(|&j| m[j]).collect();
        // Over the 48 cells other than the agent's own, which is never occluded.
        let agent = cell_index(AGENT_IN_VIEW);
        let without = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .enumerate()
                .filter(|(j, _)| *j != agent)
                .map(|(_, x)| *x)
                .collect()
        };
        let (m48, mp48, d48) = (without(m), without(&mp), without(&delta));
        r.rank_correlation = rank_correlation(&m48, &d48);
        r.chance_rank_correlation = rank_correlation(&mp48, &d48);
        if !delta_constant {
            r.argmax_agreement = Some(argmax(&m48) == argmax(&d48));
            r.chance_argmax_agreement = Some(argmax(&mp48) == argmax(&d48));
        }
        if objects.len() >= 2 {
            let truth = best_object(&delta);
            r.object_agreement = Some(best_object(m) == truth);
            r.chance_object_agreement = Some(best_object(&mp) == truth);
        }
        permuted = Some(mp);
    }
    // Deletion and insertion: M order (attention), random orders, Δ order.
    let mut orders: Vec<Vec<ViewCell>> = Vec::new();
    if let Some(m) = &m {
        orders.push(ranked(&objects, m));
    }
    orders.push(ranked(&objects, &delta));
    for _ in 0..RANDOM_ORDERS {
        let mut o = objects.clone();
        o.shuffle(rng);
        orders.push(o);
    }
    let reference = f64::from(input.probs[input.action]);
    let (del, ins) = curves(input, &objects, &orders)?;
    let k = usize::from(m.is_some());
    for (curves, out) in [(&del, &mut r.deletion), (&ins, &mut r.insertion)] {
        if m.is_some() {
            out.by_m = summarise(&curves[0], reference);
        }
        out.oracle = summarise(&curves[k], reference);
        let random: Vec<(Vec<f64>, f64)> = curves[k + 1..]
            .iter()
            .filter_map(|c| summarise(c, reference))
            .collect();
        if !random.is_empty() {
            let shapes: Vec<Vec<f64>> = random.iter().map(|(c, _)| c.clone()).collect();
            let auc = random.iter().map(|(_, a)| a).sum::<f64>() / random.len() as f64;
            out.random = Some((mean_of(&shapes), auc));
        }
    }
    // One-step interventions on M, one forward for all of them.
    if let (Some(m), Some(mp), true) = (&m, &permuted, input.agent.takes_interventions()) {
        let mut named: Vec<(&'static str, Vec<f64>)> = vec![
            ("uniform", vec![1.0 / N_CELLS as f64; N_CELLS]),
            ("permuted", mp.clone()),
        ];
        if let Some(s) = steered(m, &targets, &objects) {
            named.push(("steered", s));
        }
        let rows: Vec<f32> = named
            .iter()
            .flat_map(|(_, v)| v.iter().map(|x| *x as f32))
            .collect();
        let set = Tensor::from_vec(rows, (named.len(), N_CELLS), &Device::Cpu)?;
        let batch = vec![input.obs; named.len()];
        let probs = forward(input, &batch, Some(&Intervention::SetM(set)))?;
        let top = |p: &[f32]| argmax(&p.iter().map(|x| f64::from(*x)).collect::<Vec<_>>());
        for ((name, _), p) in named.iter().zip(&probs) {
            r.interventions.insert(
                name,
                Effect {
                    tv: total_variation(input.probs, p),
                    flip: top(p) != top(input.probs),
                },
            );
        }
    }
    if let Some(att) = input.attention {
        r.localisation = localise(&input.words, &input.targets, att);
    }
    r.occlusion = delta;
    Ok(r)
}

/// Localisation of each kind of word's map on the cells it names ([`StepInput::words`]: a
/// type, colour or door word on the visible objects it names, a location word on its
/// referents) — the first word of each kind in the mission — and of `M` on `targets`.
pub fn localise(
    words: &[WordTargets],
    targets: &[ViewCell],
    att: &AttentionTrace,
) -> BTreeMap<WordKind, Localisation> {
    let cells = |v: &[ViewCell]| -> Vec<usize> { v.iter().copied().map(cell_index).collect() };
    let mut out = BTreeMap::new();
    for t in words {
        if out.contains_key(&t.kind) {
            continue;
        }
        if let Some(w) = att.words.get(t.word)
            && let Some(l) = localisation(&flat(&w.map), &cells(&t.cells))
        {
            out.insert(t.kind, l);
        }
    }
    if let Some(l) = localisation(&flat(&att.combined), &cells(targets)) {
        out.insert(WordKind::Combined, l);
    }
    out
}

/// The objects a step's measures rank and steer between: keys, balls and boxes, or the doors
/// where every one of `M`'s targets in view is a door (GoToDoor, OpenDoor): a door's
/// distractor is another door.
pub fn candidate_objects(obs: &Observation, targets: &[ViewCell]) -> Vec<ViewCell> {
    let is_door = |&(x, y): &ViewCell| {
        crate::env::object::ObjectKind::from_index(obs.image[x][y][0])
            == Some(crate::env::object::ObjectKind::Door)
    };
    let doors = !targets.is_empty() && targets.iter().all(is_door);
    visible_objects(obs, |k, _| {
        if doors {
            k == crate::env::object::ObjectKind::Door
        } else {
            k.can_pickup()
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steering_moves_the_target_mass_to_the_nearest_distractor() {
        let mut m = vec![0.0; N_CELLS];
        m[cell_index((3, 3))] = 0.5;
        m[cell_index((0, 0))] = 0.1;
        let s = steered(&m, &[(3, 3)], &[(3, 3), (5, 3), (0, 0)]).unwrap();
        assert_eq!(s[cell_index((3, 3))], 0.0);
        assert_eq!(s[cell_index((5, 3))], 0.5);
        assert_eq!(s[cell_index((0, 0))], 0.1);
        assert!((s.iter().sum::<f64>() - 0.6).abs() < 1e-12);
        assert_eq!(steered(&m, &[(3, 3)], &[(3, 3)]), None);
        assert_eq!(steered(&m, &[], &[(5, 3)]), None);
    }

    #[test]
    fn only_visible_non_floor_cells_other_than_the_agent_are_occluded() {
        let mut obs = Observation {
            image: [[EMPTY_FLOOR; VIEW_SIZE]; VIEW_SIZE],
        };
        obs.image[0][0] = [0, 0, 0]; // unseen
        obs.image[1][0] = [2, 5, 0]; // wall
        obs.image[3][3] = [6, 0, 0]; // ball
        obs.image[AGENT_IN_VIEW.0][AGENT_IN_VIEW.1] = [5, 1, 0]; // carried key
        assert_eq!(occludable(&obs), [(1, 0), (3, 3)]);
    }
}
