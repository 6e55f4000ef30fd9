//! What one step of an episode shows, computed once from its [`StepRecord`] and shared by every
//! sink (Rerun, MCAP, the debugger): the pictures, the maps with their colour scale, and the
//! grounding hits and misses at each related object.

use image::{RgbImage, RgbaImage};

use crate::env::Pos;
use crate::env::roles::DescPart;
use crate::env::tree::{InstructionTree, Stage, pending_target_cells};
use crate::env::view::ViewCell;
use crate::env::world::{Action, World};
use crate::env::world_from_view;
use crate::episode::{EpisodeTrace, StepRecord};
use crate::metrics::grounding::{EvaluatedMap, ObjectHit, ground_step};
use crate::policy::ViewMap;
use crate::render::overlay::{CellMark, map_cells};
use crate::render::palette::{self, GROUNDING_HIT, GROUNDING_MISS, GROUNDING_NEAR, Rgb};
use crate::render::{
    colorize, draw_trail, outline_targets, overlay_on_world, render_view, render_world,
    ring_referents,
};

pub use super::accuracy_lines::{accuracy_rows, no_accuracy_reason, shown_kinds};

/// Pixels per world or view cell in recorded pictures: small enough for ≤ 20 KB a step,
/// large enough to tell a key from a ball.
pub const TILE_PX: u32 = 16;

/// A word weight below this rounds to 0.00: its map hardly enters `M`, so every display
/// greys it out.
pub const NEGLIGIBLE_WEIGHT: f32 = 0.005;

/// Opacity of an attention map projected onto the world.
pub const OVERLAY_ALPHA: f32 = 0.6;

/// Everything a sink shows for one step.
#[derive(Clone, Debug)]
pub struct StepScene {
    /// The world with the agent's visible cells highlighted.
    pub world: RgbImage,
    /// The agent's view, agent-up.
    pub view: RgbImage,
    /// The combined map `M` projected onto the world, one RGBA pixel per world cell
    /// (transparent outside the view); `None` for the baseline.
    pub overlay: Option<RgbaImage>,
    /// The upper end of the colour scale shared by all maps of this step (the largest value of
    /// any word map or `M`); the lower end is 0.
    pub scale_max: f32,
    /// Hits and misses, per evaluated map.
    pub grounding: Vec<EvaluatedMap>,
    /// The instruction tree: stages, each clause's targets, doors.
    pub tree: InstructionTree,
    /// The clause numbers on the world picture, each with the cell it is written in.
    pub clauses: Vec<ClauseMark>,
}

impl StepScene {
    /// Computes the scene of `step` of an episode, each word grounded on its own clause.
    pub fn new(step: &StepRecord, alpha: f64) -> Self {
        let world = render_world(&step.world, TILE_PX, true);
        let view = render_view(&step.obs, TILE_PX);
        let scale_max = step_scale_max(step);
        let overlay = step
            .attention
            .as_ref()
            .map(|att| attention_layer(&step.world, &att.combined, scale_max));
        let tree = InstructionTree::of(&step.world);
        Self {
            world,
            view,
            overlay,
            scale_max,
            grounding: step_grounding(step, alpha),
            clauses: clause_marks(&tree, &step.world),
            tree,
        }
    }

    /// The hits of the map of word `i` (`None`: of `M`), if that map was evaluated.
    pub fn hits_of(&self, word: Option<usize>) -> Option<&EvaluatedMap> {
        self.grounding.iter().find(|g| g.word == word)
    }
}

/// The upper end of the colour scale of `step`'s maps ([`StepScene::scale_max`]): 1 for a
/// model without maps.
pub fn step_scale_max(step: &StepRecord) -> f32 {
    step.attention.as_ref().map_or(1.0, |att| {
        att.words
            .iter()
            .flat_map(|w| w.map.iter().flatten())
            .chain(att.combined.iter().flatten())
            .fold(f32::EPSILON, |m, &v| m.max(v))
    })
}

/// The upper end of a map's own colour scale: its largest value (never 0, so that a scale
/// `0..=hi` stays a scale). The debugger's "own scale" draws each map on it.
pub fn map_scale_max(map: &ViewMap) -> f32 {
    map.iter().flatten().fold(f32::EPSILON, |m, &v| m.max(v))
}

/// The hits and misses of `step`'s maps ([`StepScene::grounding`]) without the pictures: what
/// a search over every step of an episode needs.
pub fn step_grounding(step: &StepRecord, alpha: f64) -> Vec<EvaluatedMap> {
    let Some(att) = &step.attention else {
        return Vec::new();
    };
    let words: Vec<(&str, &ViewMap)> = att
        .words
        .iter()
        .map(|w| (w.word.as_str(), &w.map))
        .collect();
    ground_step(&step.world, &step.obs, &words, &att.combined, alpha).evaluated
}

/// A view map projected onto the world grid: one RGBA pixel per world cell, the map's viridis
/// colour at [`OVERLAY_ALPHA`] on the empty floor cells the view covers, transparent
/// elsewhere (occupied cells get a ring instead, [`attention_rings`], so that objects keep
/// their colours). Scale the image by the tile size to lay it over a world render.
pub fn attention_layer(world: &World, map: &ViewMap, scale_max: f32) -> RgbaImage {
    let (w, h) = (world.grid.width() as u32, world.grid.height() as u32);
    let mut img = RgbaImage::new(w, h);
    let a = (OVERLAY_ALPHA * 255.0).round() as u8;
    for ((x, y), value, mark) in map_cells(world, map) {
        if mark == CellMark::Tint {
            let [r, g, b] = colorize(value, 0.0, scale_max);
            img.put_pixel(x as u32, y as u32, image::Rgba([r, g, b, a]));
        }
    }
    img
}

/// The occupied cells (objects, walls, doors, the agent) a view map covers, with the map's
/// colour there: drawn as rings so that what is inside keeps its colours.
pub fn attention_rings(world: &World, map: &ViewMap, scale_max: f32) -> Vec<(Pos, Rgb)> {
    map_cells(world, map)
        .into_iter()
        .filter(|(_, _, m)| matches!(m, CellMark::Ring | CellMark::Inset))
        .map(|(p, v, _)| (p, colorize(v, 0.0, scale_max)))
        .collect()
}

/// The cells the agent stood on before step `k` of `trace`, oldest first, each once, without
/// the cell it stands on at `k`.
pub fn trail(trace: &EpisodeTrace, k: usize) -> Vec<Pos> {
    let now = trace.steps.get(k).map(|s| s.world.agent_pos);
    let mut seen = std::collections::BTreeSet::new();
    trace
        .steps
        .iter()
        .take(k)
        .map(|s| s.world.agent_pos)
        .filter(|p| Some(*p) != now && seen.insert(*p))
        .collect()
}

/// The colour of an object's grounding mark: hit on its cell, only near it, or a miss.
pub fn hit_color(h: &ObjectHit) -> Rgb {
    if h.acc {
        GROUNDING_HIT
    } else if h.acc_ng || h.acc_bs {
        GROUNDING_NEAR
    } else {
        GROUNDING_MISS
    }
}

/// The world cells of the objects an evaluated map is scored on (a word's related objects:
/// the keys "key" names, the goal cells of "goal", the lava of "lava"), each with its
/// grounding mark's colour ([`hit_color`]): what a world picture under that map circles
/// ([`ring_referents`]). None where the map was not evaluated (`g` is `None`).
pub fn referent_marks(world: &World, g: Option<&EvaluatedMap>) -> Vec<(Pos, Rgb)> {
    g.map_or_else(Vec::new, |g| {
        g.hits
            .iter()
            .map(|h| {
                let pos = world_from_view(world.agent_pos, world.agent_dir, h.cell);
                (pos, hit_color(h))
            })
            .collect()
    })
}

/// The scene's world picture with `M` over the view's cells on the step's shared colour scale
/// (floor tinted, occupied cells ringed: objects keep their colours), the targets of the
/// clauses the verifier waits on (`M`'s) outlined and the agent's earlier cells (`trail`)
/// dotted. The baseline gets no map.
pub fn world_with_overlay(step: &StepRecord, scene: &StepScene, trail: &[Pos]) -> RgbImage {
    let map = step.attention.as_ref().map(|a| &a.combined);
    world_picture(step, &scene.world, map, scene.scale_max, trail, &[])
}

/// [`world_with_overlay`] with any map (a word's, or none) laid over `world`, the step's
/// world render, on the scale `0..=scale_max`, and `referents` (the cells the map's word
/// names, [`referent_marks`]) circled in their grounding colours.
pub fn world_picture(
    step: &StepRecord,
    world: &RgbImage,
    map: Option<&ViewMap>,
    scale_max: f32,
    trail: &[Pos],
    referents: &[(Pos, Rgb)],
) -> RgbImage {
    let mut img = world.clone();
    draw_trail(&mut img, trail, TILE_PX);
    if let Some(map) = map {
        overlay_on_world(
            &mut img,
            &step.world,
            map,
            TILE_PX,
            OVERLAY_ALPHA,
            0.0,
            scale_max,
        );
    }
    ring_referents(&mut img, referents, TILE_PX);
    outline_targets(&mut img, &pending_target_cells(&step.world), TILE_PX);
    img
}

/// Steps whose scenes a recording holds at once: a block is computed, written and dropped,
/// so that a recording's memory stays flat whatever the episode's length (a 22×22 world's
/// scene weighs about 0.4 MB; a whole 1,728-step BossLevel episode's, 700 MB).
pub const SCENE_BLOCK: usize = 16;

/// The scenes of `trace`'s steps from `first`, at most [`SCENE_BLOCK`] of them (each step
/// grounded on its own instruction, which a probing edit may have changed).
pub fn scene_block(trace: &EpisodeTrace, first: usize, alpha: f64) -> Vec<StepScene> {
    trace
        .steps
        .iter()
        .skip(first)
        .take(SCENE_BLOCK)
        .map(|s| StepScene::new(s, alpha))
        .collect()
}

/// The first step of every block of `trace` ([`scene_block`]).
pub fn block_starts(trace: &EpisodeTrace) -> impl Iterator<Item = usize> {
    (0..trace.steps.len()).step_by(SCENE_BLOCK)
}

/// Calls `f(first step, scenes)` on each block of `trace` in order, computed here one at a
/// time ([`scene_block`]); stops at the first error.
pub fn for_each_block<E>(
    trace: &EpisodeTrace,
    alpha: f64,
    mut f: impl FnMut(usize, &[StepScene]) -> Result<(), E>,
) -> Result<(), E> {
    for first in block_starts(trace) {
        f(first, &scene_block(trace, first, alpha))?;
    }
    Ok(())
}

/// Calls `f(episode, first step, scenes)` on each block of each episode in order, computing
/// the next block on a second thread meanwhile (two blocks held at most); stops at the first
/// error.
pub fn with_scene_blocks<E>(
    episodes: &[EpisodeTrace],
    alpha: f64,
    mut f: impl FnMut(&EpisodeTrace, usize, &[StepScene]) -> Result<(), E>,
) -> Result<(), E> {
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        scope.spawn(move || {
            for (e, ep) in episodes.iter().enumerate() {
                for first in block_starts(ep) {
                    if tx.send((e, first, scene_block(ep, first, alpha))).is_err() {
                        return;
                    }
                }
            }
        });
        for (e, first, scenes) in rx {
            f(&episodes[e], first, &scenes)?;
        }
        Ok(())
    })
}

/// Centre of view cell `(vx, vy)` in a 7×7 map image with one unit per cell.
pub fn cell_centre(cell: ViewCell) -> (f32, f32) {
    (cell.0 as f32 + 0.5, cell.1 as f32 + 0.5)
}

/// `"1"` for clause 0's description, `"1'"` for its second (PutNext's `fixed`).
pub fn clause_label(clause: usize, part: DescPart) -> String {
    match part {
        DescPart::Desc => format!("{}", clause + 1),
        DescPart::Fixed => format!("{}'", clause + 1),
    }
}

/// The colour every display gives a clause's stage.
pub fn stage_color(stage: Stage) -> Rgb {
    match stage {
        Stage::Waiting => palette::TARGET,
        Stage::Done => palette::CLAUSE_DONE,
        Stage::Later => palette::CLAUSE_LATER,
    }
}

/// One cell's clause numbers on a world picture: every clause whose targets include the cell
/// (`"2 3"` where a door matches clauses 2 and 3), in the colour of the most pressing stage
/// among them (waiting, then later, then done).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ClauseMark {
    /// The cell.
    pub pos: Pos,
    /// The clause numbers, e.g. `"1"`, `"1'"`, `"2 3"`.
    pub label: String,
    /// The stage whose colour it takes.
    pub stage: Stage,
    /// The cell the numbers are written in: a free floor cell beside `pos`, so that they
    /// cover no object, door or wall ([`label_cell`]); `pos` itself where none is free.
    pub label_at: Pos,
}

/// The clause marks of a tree's targets on `world`'s grid, one per cell, in the order the
/// targets come, each with the cell its numbers are written in ([`label_cell`]); none for a
/// mission of one clause and one description, whose targets the magenta corners already mark.
pub fn clause_marks(tree: &InstructionTree, world: &World) -> Vec<ClauseMark> {
    let mut out: Vec<ClauseMark> = Vec::new();
    if !tree.is_compound() {
        return out;
    }
    let rank = |s: Stage| match s {
        Stage::Waiting => 0,
        Stage::Later => 1,
        Stage::Done => 2,
    };
    for node in tree.clauses() {
        let Some(c) = node.clause else { continue };
        for t in &node.targets {
            let Some(pos) = t.pos else { continue };
            let label = clause_label(c, t.part);
            match out.iter_mut().find(|m| m.pos == pos) {
                Some(m) => {
                    m.label = format!("{} {label}", m.label);
                    if rank(node.stage) < rank(m.stage) {
                        m.stage = node.stage;
                    }
                }
                None => out.push(ClauseMark {
                    pos,
                    label,
                    stage: node.stage,
                    label_at: pos,
                }),
            }
        }
    }
    let mut taken: Vec<Pos> = out.iter().map(|m| m.pos).collect();
    for m in &mut out {
        if let Some(at) = label_cell(world, m.pos, &taken) {
            m.label_at = at;
            taken.push(at);
        }
    }
    out
}

/// A cell beside `pos` to write its clause numbers in: empty floor (no object, door or wall,
/// so the numbers cover nothing the picture shows but, at times, the agent), not in `taken`
/// (the marked cells and the labels placed so far); below first, where Rerun writes a box's
/// label, then above, left, right. `None` where no neighbour is free.
pub fn label_cell(world: &World, pos: Pos, taken: &[Pos]) -> Option<Pos> {
    [(0, 1), (0, -1), (-1, 0), (1, 0)]
        .into_iter()
        .map(|(dx, dy)| (pos.0 + dx, pos.1 + dy))
        .find(|&p| world.grid.contains(p) && world.grid.get(p).is_none() && !taken.contains(&p))
}

/// `"forward 0.91"`: an action and its probability.
pub fn action_label(step: &StepRecord) -> String {
    format!(
        "{} {:.2}",
        step.action.name(),
        step.probs.get(step.action as usize).copied().unwrap_or(0.0)
    )
}

/// Action names in index order.
pub fn action_names() -> [&'static str; Action::COUNT] {
    std::array::from_fn(|i| Action::from_index(i).map_or("?", Action::name))
}

/// Each action a policy scores with its probability, in index order, from one value per action
/// it scores ([`EpisodeTrace::action_probs`]): an agent of three actions lists left, right and
/// forward, never four empty rows after them. What every display's bars and tables list.
pub fn action_rows(probs: &[f32]) -> Vec<(&'static str, f32)> {
    action_names()
        .into_iter()
        .zip(probs.iter().copied())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::level::{LevelConfig, babyai_world as world};
    use crate::metrics::grounding::WordKind;

    #[test]
    fn a_cell_several_clauses_name_gets_one_mark_with_every_number() {
        // GoToSeq's "go to a door" and "go to the red door" can both match the red door.
        let (tree, w, shared) = (0..200)
            .map(|s| world("BabyAI-GoToSeqS5R2-v0", s))
            .find_map(|w| {
                let t = InstructionTree::of(&w);
                let m = clause_marks(&t, &w);
                let shared = m.into_iter().find(|m| m.label.contains(' '))?;
                Some((t, w, shared))
            })
            .expect("a cell two clauses name in 200 seeds");
        let names: Vec<Stage> = tree
            .clauses()
            .filter(|c| c.targets.iter().any(|t| t.pos == Some(shared.pos)))
            .map(|c| c.stage)
            .collect();
        assert_eq!(shared.label.split(' ').count(), names.len());
        if names.contains(&Stage::Waiting) {
            assert_eq!(shared.stage, Stage::Waiting, "the most pressing stage");
        }
        let cells: Vec<Pos> = clause_marks(&tree, &w).iter().map(|m| m.pos).collect();
        let mut unique = cells.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(cells.len(), unique.len(), "one mark per cell");
        // One clause of one description: the magenta corners suffice.
        let one = world("BabyAI-GoToLocal-v0", 0);
        assert!(clause_marks(&InstructionTree::of(&one), &one).is_empty());
    }

    /// Clause numbers do not cover objects: each is written in a free floor cell beside its
    /// target, no two in one cell and none on a marked cell, wherever such a cell exists.
    #[test]
    fn clause_numbers_are_written_beside_their_targets_on_free_floor() {
        let (mut marks, mut beside) = (0, 0);
        for level in [
            "BabyAI-GoToSeqS5R2-v0",
            "BabyAI-BossLevel-v0",
            "BabyAI-PutNextLocal-v0",
        ] {
            for seed in 0..60 {
                let w = world(level, seed);
                let all = clause_marks(&InstructionTree::of(&w), &w);
                let mut used: Vec<Pos> = all.iter().map(|m| m.pos).collect();
                for m in &all {
                    marks += 1;
                    if m.label_at == m.pos {
                        // Only where every neighbour is occupied or already used.
                        assert_eq!(label_cell(&w, m.pos, &used), None, "{level} {seed}");
                        continue;
                    }
                    beside += 1;
                    let (dx, dy) = (m.label_at.0 - m.pos.0, m.label_at.1 - m.pos.1);
                    assert_eq!(dx.abs() + dy.abs(), 1, "{level} {seed}: next to its target");
                    assert!(
                        w.grid.get(m.label_at).is_none(),
                        "{level} {seed}: covers an object"
                    );
                    assert!(!used.contains(&m.label_at), "{level} {seed}: shares a cell");
                    used.push(m.label_at);
                }
            }
        }
        assert!(marks > 100, "{marks} marks");
        assert!(
            beside * 10 >= marks * 9,
            "{beside} of {marks} beside their targets"
        );
    }

    /// A 3-action agent's rows are its three actions; a 7-action agent's all seven, in order.
    #[test]
    fn an_agent_of_three_actions_lists_three_rows() {
        let rows = action_rows(&[0.2, 0.3, 0.5]);
        assert_eq!(rows, [("left", 0.2), ("right", 0.3), ("forward", 0.5)]);
        let all = action_rows(&[1.0 / 7.0; Action::COUNT]);
        assert_eq!(all.len(), 7);
        assert_eq!(all.last().map(|r| r.0), Some("done"));
    }

    #[test]
    fn door_and_location_are_accounted_for_only_where_the_mission_has_such_a_word() {
        let paper = LevelConfig::default().generate(0).unwrap();
        assert_eq!(
            shown_kinds(&paper),
            [WordKind::Object, WordKind::Color, WordKind::Combined]
        );
        let door = world("BabyAI-GoToDoor-v0", 0);
        assert!(shown_kinds(&door).contains(&WordKind::Door));
        assert!(!shown_kinds(&door).contains(&WordKind::Location));
    }
}
