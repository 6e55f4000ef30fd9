//! The paper's grounding accuracies (§4.2, eqs. 8–11): does a word's attention map cover the
//! objects the word names? Every formula lives here.
//!
//! For a word ω naming a type (key/ball/box) or a colour, its related objects are the objects
//! visible in the view with that type or colour (the carried object in the agent's own cell
//! does not count; walls are not objects). A step is evaluated for ω only when n_ω ≥ 1. With
//! `τ = α / n_ω` and each related object at view cell `(x, y)` (y decreases forward):
//! - `acc`: `A[y][x] ≥ τ`;
//! - `acc_ng`: some cell within Chebyshev distance 1 of `(x, y)`, inside the view, is `≥ τ`;
//! - `acc_bs`: the cell one step forward, `(x, y − 1)`, is `≥ τ` (needs `y > 0`);
//! - `acc_cmb`: `acc` or `acc_bs` (just `acc` when `y = 0`).
//!
//! Each is the fraction of the n_ω objects that hit. Maps are `map[vy][vx]`, agent-up.
//!
//! On every BabyAI instruction kind (docs/evaluation.md#what-each-word-names) each word is
//! evaluated on its own clause's description ([`crate::env::roles`]): a type word on the
//! visible objects of that type, a colour word on the visible objects of that colour and of
//! its description's category (keys, balls and boxes, or doors), "door" on the visible doors,
//! a location word on the objects its description matched (the verifier's set, visible cells
//! only); verbs, articles and joining words are not scored. `M` is evaluated on the objects
//! the clauses the verifier is waiting on matched ([`pending_targets`]). On the paper's level
//! this is exactly the paper's definition: one clause, no doors, no location words.
//! Beyond the paper, `around` says *where* in the neighbourhood a map passes τ: for each of
//! the nine cells [`AROUND`] of an object's 3×3 neighbourhood, the fraction of objects whose
//! cell at that offset is `≥ τ` (so `around[4]` is `acc` and `around[1]` is `acc_bs`). A map
//! that settles beside its objects shows there which side it settled on.

use serde::{Deserialize, Serialize};

pub use crate::env::targets::{
    WordKind, WordTargets, location_region, pending_targets, related_objects, visible_cells_of,
    visible_objects, word_targets,
};
use crate::env::view::{Observation, VIEW_SIZE, ViewCell};
use crate::env::world::World;
use crate::policy::ViewMap;

/// The nine cells of an object's 3×3 neighbourhood as view offsets `(dx, dy)`, row by row
/// from the row one step forward (`dy = −1`) to the row one step back, each left to right.
pub const AROUND: [(i64, i64); 9] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (0, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// Short names of the [`AROUND`] offsets as seen from the agent, for tables.
pub const AROUND_NAMES: [&str; 9] = [
    "forward-left",
    "forward",
    "forward-right",
    "left",
    "on",
    "right",
    "back-left",
    "back",
    "back-right",
];

/// The four accuracies of one map at one step, each a fraction of the related objects, and
/// the hit rate at each offset of [`AROUND`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Accuracies {
    /// Hit on the object's own cell.
    pub acc: f64,
    /// Hit anywhere in its 3×3 neighbourhood.
    pub acc_ng: f64,
    /// Hit on the cell one step forward.
    pub acc_bs: f64,
    /// `acc` or `acc_bs`.
    pub acc_cmb: f64,
    /// The fraction of objects whose cell at each offset of [`AROUND`] is `≥ τ`.
    #[serde(default)]
    pub around: [f64; 9],
    /// The pointing game: whether the map's largest cell is on a related object (ties shared:
    /// the fraction of the largest cells that are related).
    #[serde(default)]
    pub pointing: f64,
    /// Relevance mass: the map's mass on the related objects' cells.
    #[serde(default)]
    pub mass: f64,
    /// Chance: a uniform map's values on the same objects.
    #[serde(default)]
    pub chance: Chance,
    /// Location words only: the map's mass inside the half-plane the word names, fixed at
    /// reset by the agent's start pose (minigrid's verifier) and carried into the current
    /// view ([`location_region`]); `None` for every other map.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<f64>,
    /// A uniform map's region mass: the share of the view's cells inside the half-plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region_chance: Option<f64>,
}

/// The sum of two optional figures (one kind's steps all have it or all lack it).
fn add_opt(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x + y),
        (x, y) => x.or(y),
    }
}

/// What a uniform map (1/49 on every cell) scores on the same objects: the rate each figure
/// of [`Accuracies`] is read against. Its pointing game and its mass are both `n / 49`; its
/// `acc` is 0 unless the objects are so many that `α / n ≤ 1/49`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Chance {
    /// A uniform map's `acc`.
    pub acc: f64,
    /// Its `acc_ng`.
    pub acc_ng: f64,
    /// Its `acc_bs`.
    pub acc_bs: f64,
    /// Its `acc_cmb`.
    pub acc_cmb: f64,
    /// Its pointing game.
    pub pointing: f64,
    /// Its relevance mass.
    pub mass: f64,
}

impl Chance {
    fn values(self) -> [f64; 6] {
        [
            self.acc,
            self.acc_ng,
            self.acc_bs,
            self.acc_cmb,
            self.pointing,
            self.mass,
        ]
    }

    fn from_values(v: [f64; 6]) -> Self {
        Self {
            acc: v[0],
            acc_ng: v[1],
            acc_bs: v[2],
            acc_cmb: v[3],
            pointing: v[4],
            mass: v[5],
        }
    }
}

impl Accuracies {
    /// The six figures in report order: the paper's four, the pointing game, relevance mass.
    pub fn all_values(&self) -> [f64; 6] {
        [
            self.acc,
            self.acc_ng,
            self.acc_bs,
            self.acc_cmb,
            self.pointing,
            self.mass,
        ]
    }

    /// Names of [`Self::all_values`], in report order.
    pub const ALL_NAMES: [&'static str; 6] =
        ["acc", "acc_ng", "acc_bs", "acc_cmb", "pointing", "mass"];

    /// The four values in report order.
    pub fn values(&self) -> [f64; 4] {
        [self.acc, self.acc_ng, self.acc_bs, self.acc_cmb]
    }

    /// Names of the four values, in report order.
    pub const NAMES: [&'static str; 4] = ["acc", "acc_ng", "acc_bs", "acc_cmb"];

    /// Element-wise sum.
    pub fn add(&mut self, o: &Self) {
        self.acc += o.acc;
        self.acc_ng += o.acc_ng;
        self.acc_bs += o.acc_bs;
        self.acc_cmb += o.acc_cmb;
        for (a, b) in self.around.iter_mut().zip(o.around) {
            *a += b;
        }
        self.pointing += o.pointing;
        self.mass += o.mass;
        let (c, d) = (self.chance.values(), o.chance.values());
        self.chance = Chance::from_values(std::array::from_fn(|i| c[i] + d[i]));
        self.region = add_opt(self.region, o.region);
        self.region_chance = add_opt(self.region_chance, o.region_chance);
    }

    /// Element-wise division.
    #[must_use]
    pub fn scaled(&self, by: f64) -> Self {
        Self {
            acc: self.acc / by,
            acc_ng: self.acc_ng / by,
            acc_bs: self.acc_bs / by,
            acc_cmb: self.acc_cmb / by,
            around: self.around.map(|a| a / by),
            pointing: self.pointing / by,
            mass: self.mass / by,
            chance: Chance::from_values(self.chance.values().map(|c| c / by)),
            region: self.region.map(|r| r / by),
            region_chance: self.region_chance.map(|r| r / by),
        }
    }
}

/// Hit or miss of one related object under each of the four criteria.
#[expect(
    clippy::struct_excessive_bools,
    reason = "one flag per criterion of eqs. 8–11"
)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ObjectHit {
    /// The object's view cell `(vx, vy)`.
    pub cell: ViewCell,
    /// `A[y][x] ≥ τ`.
    pub acc: bool,
    /// Some cell of the 3×3 neighbourhood is `≥ τ`.
    pub acc_ng: bool,
    /// The cell one step forward is `≥ τ`.
    pub acc_bs: bool,
    /// `acc` or `acc_bs`.
    pub acc_cmb: bool,
    /// Whether the cell at each offset of [`AROUND`] is `≥ τ` (outside the view: no).
    #[serde(default)]
    pub around: [bool; 9],
}

/// Hit or miss of each object in `objects` on `map` at threshold `α / n` (n = the number of
/// objects), in the order given. Every criterion of eqs. 8–11 is decided here only.
pub fn object_hits(map: &ViewMap, objects: &[ViewCell], alpha: f64) -> Vec<ObjectHit> {
    let tau = alpha / objects.len().max(1) as f64;
    let at = |x: i64, y: i64| -> Option<f64> {
        let r = 0..VIEW_SIZE as i64;
        (r.contains(&x) && r.contains(&y)).then(|| f64::from(map[y as usize][x as usize]))
    };
    objects
        .iter()
        .map(|&cell| {
            let (x, y) = (cell.0 as i64, cell.1 as i64);
            let around = AROUND.map(|(dx, dy)| at(x + dx, y + dy).is_some_and(|v| v >= tau));
            // The paper's criteria are cells of the neighbourhood: on it, any, one forward.
            let (acc, acc_bs) = (around[4], around[1]);
            ObjectHit {
                cell,
                acc,
                acc_ng: around.contains(&true),
                acc_bs,
                acc_cmb: acc || acc_bs,
                around,
            }
        })
        .collect()
}

/// The uniform map: chance.
pub const UNIFORM_MAP: ViewMap = [[1.0 / 49.0; VIEW_SIZE]; VIEW_SIZE];

/// Every figure of `map` on `objects` at threshold `α / n`, with chance beside them; `None`
/// when there is no related object (the step is not evaluated).
pub fn accuracies(map: &ViewMap, objects: &[ViewCell], alpha: f64) -> Option<Accuracies> {
    if objects.is_empty() {
        return None;
    }
    Some(map_figures(
        map,
        objects,
        &object_hits(map, objects, alpha),
        alpha,
    ))
}

/// The pointing game of `map` on `objects`: the fraction of the map's largest cells that hold
/// a related object (1 or 0 for a single largest cell; a uniform map scores `n / 49`).
pub fn pointing(map: &ViewMap, objects: &[ViewCell]) -> f64 {
    let (flat, related) = flat_cells(map, objects);
    pointing_flat(&flat, &related)
}

/// Relevance mass of `map` on `objects`: its mass on their cells.
pub fn relevance_mass(map: &ViewMap, objects: &[ViewCell]) -> f64 {
    let (flat, related) = flat_cells(map, objects);
    relevance_mass_flat(&flat, &related)
}

/// [`pointing`] of a map given as values and the indices of its related cells: the one
/// formula of the pointing game (the faithfulness tests' localisation uses it too).
pub fn pointing_flat(map: &[f64], related: &[usize]) -> f64 {
    let top = map.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    let largest: Vec<usize> = (0..map.len()).filter(|&j| map[j] == top).collect();
    let on = largest.iter().filter(|j| related.contains(j)).count();
    on as f64 / largest.len().max(1) as f64
}

/// [`relevance_mass`] of a map given as values and the indices of its related cells.
pub fn relevance_mass_flat(map: &[f64], related: &[usize]) -> f64 {
    related.iter().filter_map(|&j| map.get(j)).sum()
}

/// `map` as 49 values (row by row, agent-up) and the indices of `objects`' cells.
fn flat_cells(map: &ViewMap, objects: &[ViewCell]) -> (Vec<f64>, Vec<usize>) {
    let flat = map.iter().flatten().map(|&v| f64::from(v)).collect();
    let related = objects.iter().map(|&(x, y)| y * VIEW_SIZE + x).collect();
    (flat, related)
}

/// The paper's four accuracies over `hits` (the objects' hits on `map`), the pointing game and
/// relevance mass of `map` on `objects`, and a uniform map's values on the same objects.
pub fn map_figures(
    map: &ViewMap,
    objects: &[ViewCell],
    hits: &[ObjectHit],
    alpha: f64,
) -> Accuracies {
    let uniform = accuracies_of_hits(&object_hits(&UNIFORM_MAP, objects, alpha));
    Accuracies {
        pointing: pointing(map, objects),
        mass: relevance_mass(map, objects),
        chance: Chance {
            acc: uniform.acc,
            acc_ng: uniform.acc_ng,
            acc_bs: uniform.acc_bs,
            acc_cmb: uniform.acc_cmb,
            pointing: pointing(&UNIFORM_MAP, objects),
            mass: relevance_mass(&UNIFORM_MAP, objects),
        },
        ..accuracies_of_hits(hits)
    }
}

/// The fraction of `hits` that hit under each criterion (all zero for no objects); the
/// pointing game, mass and chance are left at zero ([`map_figures`] fills them).
pub fn accuracies_of_hits(hits: &[ObjectHit]) -> Accuracies {
    let mut sum = Accuracies::default();
    for h in hits {
        sum.acc += f64::from(u8::from(h.acc));
        sum.acc_ng += f64::from(u8::from(h.acc_ng));
        sum.acc_bs += f64::from(u8::from(h.acc_bs));
        sum.acc_cmb += f64::from(u8::from(h.acc_cmb));
        for (a, hit) in sum.around.iter_mut().zip(h.around) {
            *a += f64::from(u8::from(hit));
        }
    }
    sum.scaled(hits.len().max(1) as f64)
}

/// One map evaluated at one step.
#[derive(Clone, Debug, PartialEq)]
pub struct EvaluatedMap {
    /// Object word, colour word, door, location word, or `M` on the targets.
    pub kind: WordKind,
    /// Index of the map's word in the mission (`None` for `M`).
    pub word: Option<usize>,
    /// The four accuracies over [`Self::hits`].
    pub accuracies: Accuracies,
    /// Hit or miss of each related object in view.
    pub hits: Vec<ObjectHit>,
}

/// The evaluations of one step: one entry per evaluated word map, then `M`'s.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepGrounding {
    /// Per word: the map's word, its accuracies and each related object's hit.
    pub evaluated: Vec<EvaluatedMap>,
}

/// Evaluates one step of `world` (the world the agent saw, `obs`): each scored word's map on
/// the cells [`word_targets`] gives it, and `M` on [`pending_targets`]. `words` are the
/// mission's words with their maps, in order.
pub fn ground_step(
    world: &World,
    obs: &Observation,
    words: &[(&str, &ViewMap)],
    combined: &ViewMap,
    alpha: f64,
) -> StepGrounding {
    let mut out = StepGrounding::default();
    let mut evaluate = |kind: WordKind,
                        word: Option<usize>,
                        map: &ViewMap,
                        objs: &[ViewCell],
                        region: Option<&[ViewCell]>| {
        if !objs.is_empty() {
            let hits = object_hits(map, objs, alpha);
            let mut accuracies = map_figures(map, objs, &hits, alpha);
            if let Some(r) = region {
                accuracies.region = Some(relevance_mass(map, r));
                accuracies.region_chance = Some(relevance_mass(&UNIFORM_MAP, r));
            }
            out.evaluated.push(EvaluatedMap {
                kind,
                word,
                accuracies,
                hits,
            });
        }
    };
    for t in word_targets(world, obs, words.len()) {
        evaluate(
            t.kind,
            Some(t.word),
            words[t.word].1,
            &t.cells,
            t.region.as_deref(),
        );
    }
    evaluate(
        WordKind::Combined,
        None,
        combined,
        &pending_targets(world, obs),
        None,
    );
    out
}

#[cfg(test)]
mod tests;
