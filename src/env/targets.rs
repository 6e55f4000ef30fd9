//! What each word of a mission names at a step, in the agent's view: the cells of the objects
//! a type, colour or door word names, a location word's referents and its half-plane, and the
//! objects the clauses still waited on matched (`M`'s targets). World facts, read from the
//! instruction tree ([`super::roles`], [`super::tree`]); the metrics score maps on them
//! (`metrics::grounding`, whose header gives the definitions) and training may supervise maps
//! with them (`train --ground-loss`).

use serde::{Deserialize, Serialize};

use super::object::{Color, ObjectId, ObjectKind};
use super::roles::{DescPart, WordClass, word_roles};
use super::tree::pending_target_ids;
use super::view::{AGENT_IN_VIEW, Observation, VIEW_SIZE, ViewCell, view_from_world};
use super::world::World;

/// Visible objects (keys, balls, boxes) in the view that satisfy `pred`, excluding the
/// agent's own cell.
pub fn related_objects(
    obs: &Observation,
    pred: impl Fn(ObjectKind, Color) -> bool,
) -> Vec<ViewCell> {
    visible_objects(obs, |k, c| k.can_pickup() && pred(k, c))
}

/// Visible objects of any kind but walls (keys, balls, boxes, doors) that satisfy `pred`,
/// excluding the agent's own cell, in view order.
pub fn visible_objects(
    obs: &Observation,
    pred: impl Fn(ObjectKind, Color) -> bool,
) -> Vec<ViewCell> {
    visible_cells_where(obs, |k, c| {
        (k.can_pickup() || k == ObjectKind::Door) && pred(k, c)
    })
}

/// The view cells (not the agent's own) whose encoding names a kind and colour satisfying
/// `pred`, in view order; unseen cells encode no kind a predicate asks for.
pub fn visible_cells_where(
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
            if pred(kind, color) {
                out.push((vx, vy));
            }
        }
    }
    out
}

/// The view cells inside the half-plane a location word names: minigrid's verifier fixes it
/// at reset, relative to the agent's start pose (`start`), and the agent moves since; each
/// cell of the current view is placed in the world and tested against the start pose
/// ([`super::ObjDesc::on_side`], the verifier's own test). The room is not looked at:
/// the region is the side, the referent is what the whole description selects.
pub fn location_region(world: &World, loc: super::Loc, start: (super::Pos, u8)) -> Vec<ViewCell> {
    (0..VIEW_SIZE)
        .flat_map(|vy| (0..VIEW_SIZE).map(move |vx| (vx, vy)))
        .filter(|&cell| {
            let p = super::world_from_view(world.agent_pos, world.agent_dir, cell);
            super::ObjDesc::on_side(loc, p, start.0, start.1)
        })
        .collect()
}

/// Which kind of mission word a metric is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WordKind {
    /// The object-type word (key, ball, box, object): paper Fig. 7.
    Object,
    /// The colour word: paper Fig. 8.
    Color,
    /// The combined map `M` on the target objects (not in the paper).
    Combined,
    /// "door" (BabyAI's door levels).
    Door,
    /// A location word: front, behind, left, right (BabyAI's `Loc` levels).
    Location,
    /// "goal" (MiniGrid's goal cells).
    Goal,
    /// "lava" (MiniGrid's lava cells).
    Lava,
    /// "opening" (the gaps of MiniGrid's wall rivers).
    Opening,
}

impl WordKind {
    /// All kinds, in report order.
    pub const ALL: [Self; 8] = [
        Self::Object,
        Self::Color,
        Self::Combined,
        Self::Door,
        Self::Location,
        Self::Goal,
        Self::Lava,
        Self::Opening,
    ];

    /// Lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Object => "object",
            Self::Color => "color",
            Self::Combined => "combined",
            Self::Door => "door",
            Self::Location => "location",
            Self::Goal => "goal",
            Self::Lava => "lava",
            Self::Opening => "opening",
        }
    }
}

/// The cells each scored word of `world`'s mission names at this step, by word index, with
/// the word's kind: the definitions of the module's header. Words that name nothing by
/// themselves are left out; so is every word when the mission's words do not follow the
/// instruction tree (a mission typed by hand that the tree does not read back).
pub fn word_targets(world: &World, obs: &Observation, n_words: usize) -> Vec<WordTargets> {
    if world.rules.is_some() {
        return super::minigrid::words::word_targets(world, obs, n_words);
    }
    let roles = word_roles(&world.instr);
    if roles.len() != n_words {
        return Vec::new();
    }
    let clauses = world.instr.clauses();
    let mut out = Vec::new();
    for (i, role) in roles.iter().enumerate() {
        let (Some(c), Some(part)) = (role.clause, role.desc) else {
            continue;
        };
        let Some(node) = clauses.get(c) else { continue };
        let (desc, matched) = match part {
            DescPart::Desc => (node.instr.desc, &node.targets),
            DescPart::Fixed => match node.instr.fixed {
                Some(f) => (f, &node.fixed_targets),
                None => continue,
            },
        };
        let doors = desc.kind == Some(ObjectKind::Door);
        let category = |k: ObjectKind| {
            if doors {
                k == ObjectKind::Door
            } else {
                k.can_pickup()
            }
        };
        let (kind, cells) = match role.class {
            WordClass::Object => (
                WordKind::Object,
                visible_objects(obs, |k, _| category(k) && desc.kind.is_none_or(|d| d == k)),
            ),
            WordClass::Door => (
                WordKind::Door,
                visible_objects(obs, |k, _| k == ObjectKind::Door),
            ),
            WordClass::Color => (
                WordKind::Color,
                visible_objects(obs, |k, c| category(k) && desc.color == Some(c)),
            ),
            WordClass::Location => (
                WordKind::Location,
                visible_cells_of(world, obs, &matched.obj_set),
            ),
            WordClass::Other | WordClass::Goal | WordClass::Lava | WordClass::Opening => continue,
        };
        let region = match (role.class, desc.loc, matched.pose) {
            (WordClass::Location, Some(loc), Some(start)) => {
                Some(location_region(world, loc, start))
            }
            _ => None,
        };
        out.push(WordTargets {
            word: i,
            kind,
            cells,
            region,
        });
    }
    out
}

/// What one scored word of a mission names at a step ([`word_targets`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WordTargets {
    /// The word's index in the mission.
    pub word: usize,
    /// Its class.
    pub kind: WordKind,
    /// The visible cells of the objects it names (a location word: its description's
    /// referents).
    pub cells: Vec<ViewCell>,
    /// A location word's region: the view cells in the half-plane it names.
    pub region: Option<Vec<ViewCell>>,
}

/// The visible objects the clauses the verifier is waiting on matched ([`pending_target_ids`]),
/// in view order: `M`'s targets.
pub fn pending_targets(world: &World, obs: &Observation) -> Vec<ViewCell> {
    visible_cells_of(world, obs, &pending_target_ids(world))
}

/// The view cells of the objects `ids` that are on the grid and visible (not the agent's own
/// cell), in view order (row by row from the far row).
pub fn visible_cells_of(world: &World, obs: &Observation, ids: &[ObjectId]) -> Vec<ViewCell> {
    let cells = world
        .grid
        .objects()
        .filter(|(_, o)| ids.contains(&o.id))
        .map(|(p, _)| p);
    visible_world_cells(world, obs, cells)
}

/// World cells as the visible view cells they are (not the agent's own), in view order (row by
/// row from the far row), each once.
pub fn visible_world_cells(
    world: &World,
    obs: &Observation,
    cells: impl IntoIterator<Item = super::Pos>,
) -> Vec<ViewCell> {
    let mut cells: Vec<ViewCell> = cells
        .into_iter()
        .filter_map(|p| view_from_world(world.agent_pos, world.agent_dir, p))
        .filter(|&c| c != AGENT_IN_VIEW && obs.visible(c))
        .collect();
    cells.sort_by_key(|&(vx, vy)| (vy, vx));
    cells.dedup();
    cells
}
