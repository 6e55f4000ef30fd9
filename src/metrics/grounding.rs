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
//! Beyond the paper, `around` says *where* in the neighbourhood a map passes τ: for each of
//! the nine cells [`AROUND`] of an object's 3×3 neighbourhood, the fraction of objects whose
//! cell at that offset is `≥ τ` (so `around[4]` is `acc` and `around[1]` is `acc_bs`). A map
//! that settles beside its objects shows there which side it settled on.

use serde::{Deserialize, Serialize};

use crate::env::mission::ObjDesc;
use crate::env::object::{Color, ObjectKind};
use crate::env::view::{AGENT_IN_VIEW, Observation, VIEW_SIZE, ViewCell};
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
}

impl Accuracies {
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
        }
    }
}

/// Visible objects (keys, balls, boxes) in the view that satisfy `pred`, excluding the
/// agent's own cell.
pub fn related_objects(
    obs: &Observation,
    pred: impl Fn(ObjectKind, Color) -> bool,
) -> Vec<ViewCell> {
    let mut out = Vec::new();
    for vy in 0..VIEW_SIZE {
        for vx in 0..VIEW_SIZE {
            if (vx, vy) == AGENT_IN_VIEW {
                continue;
            }
            let [t, c, _] = obs.image[vx][vy];
            let (Some(kind), Some(color)) = (ObjectKind::from_index(t), Color::from_index(c))
            else {
                continue;
            };
            if kind.can_pickup() && pred(kind, color) {
                out.push((vx, vy));
            }
        }
    }
    out
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

/// The four accuracies of `map` on `objects` at threshold `α / n`; `None` when there is no
/// related object (the step is not evaluated).
pub fn accuracies(map: &ViewMap, objects: &[ViewCell], alpha: f64) -> Option<Accuracies> {
    if objects.is_empty() {
        return None;
    }
    Some(accuracies_of_hits(&object_hits(map, objects, alpha)))
}

/// The fraction of `hits` that hit under each criterion (all zero for no objects).
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

/// Which kind of mission word a metric is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WordKind {
    /// The object-type word (key, ball, box): paper Fig. 7.
    Object,
    /// The colour word: paper Fig. 8.
    Color,
    /// The combined map `M` on the target objects (not in the paper).
    Combined,
}

impl WordKind {
    /// All kinds, in report order.
    pub const ALL: [Self; 3] = [Self::Object, Self::Color, Self::Combined];

    /// Lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Object => "object",
            Self::Color => "color",
            Self::Combined => "combined",
        }
    }
}

/// One map evaluated at one step.
#[derive(Clone, Debug, PartialEq)]
pub struct EvaluatedMap {
    /// Object word, colour word, or `M` on the targets.
    pub kind: WordKind,
    /// Index of the map's word in the mission (`None` for `M`).
    pub word: Option<usize>,
    /// The four accuracies over [`Self::hits`].
    pub accuracies: Accuracies,
    /// Hit or miss of each related object in view.
    pub hits: Vec<ObjectHit>,
}

/// The evaluations of one step: one entry per word kind that was evaluated.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepGrounding {
    /// Per word kind: the map's word, its accuracies and each related object's hit.
    pub evaluated: Vec<EvaluatedMap>,
}

/// Evaluates one step: the type word's map, the colour word's map, and `M` on the objects that
/// match the whole description. `words` are the mission's words with their maps (the first
/// word spelled like the description's type or colour is the one evaluated).
pub fn ground_step(
    obs: &Observation,
    desc: &ObjDesc,
    words: &[(&str, &ViewMap)],
    combined: &ViewMap,
    alpha: f64,
) -> StepGrounding {
    let mut out = StepGrounding::default();
    let mut evaluate = |kind: WordKind, word: Option<usize>, map: &ViewMap, objs: &[ViewCell]| {
        if !objs.is_empty() {
            let hits = object_hits(map, objs, alpha);
            out.evaluated.push(EvaluatedMap {
                kind,
                word,
                accuracies: accuracies_of_hits(&hits),
                hits,
            });
        }
    };
    let find = |name: &str| words.iter().position(|(w, _)| *w == name);
    if let Some(kind) = desc.kind
        && let Some(i) = find(kind.name())
    {
        let objs = related_objects(obs, |k, _| k == kind);
        evaluate(WordKind::Object, Some(i), words[i].1, &objs);
    }
    if let Some(color) = desc.color
        && let Some(i) = find(color.name())
    {
        let objs = related_objects(obs, |_, c| c == color);
        evaluate(WordKind::Color, Some(i), words[i].1, &objs);
    }
    evaluate(
        WordKind::Combined,
        None,
        combined,
        &target_objects(obs, *desc),
    );
    out
}

/// The visible objects matching the whole description (type and colour): the targets `M`
/// is evaluated on.
pub fn target_objects(obs: &Observation, desc: ObjDesc) -> Vec<ViewCell> {
    related_objects(obs, |k, c| {
        desc.kind.is_none_or(|d| d == k) && desc.color.is_none_or(|d| d == c)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_hot(x: usize, y: usize) -> ViewMap {
        let mut m = [[0.0; 7]; 7];
        m[y][x] = 1.0;
        m
    }

    const UNIFORM: ViewMap = [[1.0 / 49.0; 7]; 7];

    #[test]
    fn one_hot_on_the_object_hits_everything_but_the_shift() {
        let a = accuracies(&one_hot(2, 3), &[(2, 3)], 0.5).unwrap();
        assert_eq!(a.values(), [1.0, 1.0, 0.0, 1.0]);
    }

    #[test]
    fn around_says_which_side_of_the_object_the_map_passes() {
        // One object at (2, 3): a map one cell to its right; another at (5, 0): a map on it.
        let mut m = one_hot(3, 3);
        m[0][5] = 1.0;
        let a = accuracies(&m, &[(2, 3), (5, 0)], 0.5).unwrap();
        let mut want = [0.0; 9];
        want[5] = 0.5; // right of the first object
        want[4] = 0.5; // on the second
        assert_eq!(a.around, want);
        assert_eq!(a.acc, a.around[4]);
        assert_eq!(a.acc_bs, a.around[1]);
        assert_eq!(a.acc_ng, 1.0);
        // The offsets name the sides as the agent sees them (forward is up the view).
        assert_eq!(AROUND[1], (0, -1));
        assert_eq!((AROUND_NAMES[1], AROUND_NAMES[5]), ("forward", "right"));
        // A mean over steps keeps the offsets.
        let mut sum = a;
        sum.add(&accuracies(&one_hot(2, 2), &[(2, 3)], 0.5).unwrap());
        assert_eq!(sum.scaled(2.0).around[1], 0.5);
    }

    #[test]
    fn a_uniform_map_misses_at_alpha_one_half() {
        let a = accuracies(&UNIFORM, &[(2, 3)], 0.5).unwrap();
        assert_eq!(a, Accuracies::default());
        // ... and hits everywhere when α is tiny.
        let a = accuracies(&UNIFORM, &[(2, 3)], 0.01).unwrap();
        assert_eq!(a.values(), [1.0; 4]);
    }

    #[test]
    fn a_map_shifted_one_cell_forward_hits_bs_ng_and_cmb() {
        let a = accuracies(&one_hot(2, 2), &[(2, 3)], 0.5).unwrap();
        assert_eq!(a.values(), [0.0, 1.0, 1.0, 1.0]);
    }

    #[test]
    fn an_object_on_row_zero_has_no_forward_shift() {
        let mut m = one_hot(4, 0);
        m[6][0] = 0.9; // far away, irrelevant
        let a = accuracies(&m, &[(4, 0)], 0.5).unwrap();
        assert_eq!(a.values(), [1.0, 1.0, 0.0, 1.0]);
        let miss = accuracies(&one_hot(5, 1), &[(4, 0)], 0.5).unwrap();
        assert_eq!(miss.values(), [0.0, 1.0, 0.0, 0.0]);
    }

    #[test]
    fn several_objects_share_the_threshold() {
        // Two related objects: τ = 0.25; half the mass on each.
        let mut m = [[0.0; 7]; 7];
        m[1][1] = 0.3;
        m[4][5] = 0.2;
        let a = accuracies(&m, &[(1, 1), (5, 4)], 0.5).unwrap();
        assert_eq!(a.acc, 0.5, "only the first reaches τ = 0.25");
        assert_eq!(a.acc_ng, 0.5);
    }

    #[test]
    fn steps_without_related_objects_are_not_evaluated() {
        assert_eq!(accuracies(&UNIFORM, &[], 0.5), None);
        let obs = Observation {
            image: [[[1, 0, 0]; 7]; 7],
        };
        let desc = ObjDesc {
            kind: Some(ObjectKind::Key),
            color: Some(Color::Red),
            loc: None,
        };
        let g = ground_step(
            &obs,
            &desc,
            &[("key", &UNIFORM), ("red", &UNIFORM)],
            &UNIFORM,
            0.5,
        );
        assert!(g.evaluated.is_empty());
    }

    #[test]
    fn the_carried_object_and_walls_are_not_related() {
        let mut obs = Observation {
            image: [[[1, 0, 0]; 7]; 7],
        };
        obs.image[3][6] = [5, 0, 0]; // carried red key in the agent's cell
        obs.image[0][0] = [2, 5, 0]; // grey wall
        obs.image[1][2] = [5, 0, 0]; // red key at vx 1, vy 2
        assert_eq!(
            related_objects(&obs, |k, _| k == ObjectKind::Key),
            vec![(1, 2)]
        );
        assert!(related_objects(&obs, |_, c| c == Color::Grey).is_empty());
        let desc = ObjDesc {
            kind: Some(ObjectKind::Key),
            color: Some(Color::Red),
            loc: None,
        };
        let map = one_hot(1, 2);
        let g = ground_step(
            &obs,
            &desc,
            &[("go", &UNIFORM), ("key", &map), ("red", &UNIFORM)],
            &map,
            0.5,
        );
        let kinds: Vec<WordKind> = g.evaluated.iter().map(|e| e.kind).collect();
        assert_eq!(
            kinds,
            vec![WordKind::Object, WordKind::Color, WordKind::Combined]
        );
        assert_eq!(g.evaluated[0].accuracies.acc, 1.0);
        assert_eq!(g.evaluated[1].accuracies.acc, 0.0);
    }
}
