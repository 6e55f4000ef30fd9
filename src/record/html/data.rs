//! What an episode page holds for each of its panels and steps, read from the trace and its
//! [`StepScene`]s: the JSON the page's script draws from. Only what the browser cannot derive
//! is stored, and pictures are tile indices into the [`Atlas`], so that a step costs a few
//! kilobytes whatever the world's size.

use std::collections::HashMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::atlas::{Atlas, Tile};
use super::hex;
use crate::env::minigrid::Rules;
use crate::env::tree::{InstructionTree, doors_text, pending_target_cells, targets_text};
use crate::env::world::Action;
use crate::env::{Pos, VIEW_SIZE, World};
use crate::episode::{EpisodeTrace, StepRecord};
use crate::metrics::report::escape_html;
use crate::policy::ViewMap;
use crate::record::scene::{
    StepScene, accuracy_rows, action_names, for_each_block, hit_color, stage_color,
};
use crate::record::{RecordError, StopFlag, stopped};
use crate::render::overlay::{CellMark, map_cells};
use crate::render::visible_cells;

/// Map values are stored as thousandths of their step's shared scale ([`StepScene::scale_max`]):
/// finer than the 256 colours of the colour map, and two or three digits a cell.
pub(super) const MAP_LEVELS: f32 = 1000.0;

/// One episode, as a panel of the page shows it.
#[derive(Debug, Serialize)]
pub(super) struct PanelJson {
    /// Who acted: the checkpoint and its variant, or an imported graph's own name.
    title: String,
    /// The level, as every command names it.
    level: String,
    /// The level seed.
    seed: u64,
    /// Greedy or sampled.
    mode: &'static str,
    /// The mission as the policy read it.
    mission: String,
    /// Whether the episode succeeded.
    success: bool,
    /// Its return.
    total_reward: f64,
    /// The world's width and height in cells.
    width: usize,
    height: usize,
    /// The environment's action space: the bars shown (a 3-action MiniGrid level shows 3).
    actions: Vec<&'static str>,
    /// The mission's words with maps (empty for a model without maps).
    words: Vec<String>,
    /// Whether any step has minigrid's bot beside it.
    expert: bool,
    /// The grid's tiles, one entry each time the grid changed (an object picked up, a door
    /// opened): what a step's `g` indexes.
    grids: Vec<GridJson>,
    /// The instruction trees the episode went through, as HTML: what a step's `tr` indexes.
    trees: Vec<String>,
    /// The steps.
    steps: Vec<StepJson>,
}

/// The grid's tiles, row by row (`y · width + x`), unseen and seen.
#[derive(Debug, PartialEq, Eq, Serialize)]
struct GridJson {
    unlit: Vec<usize>,
    lit: Vec<usize>,
}

/// One step. Cells of the world are numbered `y · width + x`; view cells `vy · 7 + vx`.
#[derive(Debug, Serialize)]
struct StepJson {
    /// The grid ([`PanelJson::grids`]).
    g: usize,
    /// The agent's cell and direction: `[x, y, dir]` (the page derives the trail from them).
    ag: [i32; 3],
    /// The agent's tile in the world picture.
    at: usize,
    /// The world cells the agent sees (highlighted).
    vis: Vec<usize>,
    /// The view's tiles.
    view: Vec<usize>,
    /// The cells of `M`'s targets (magenta corners).
    tg: Vec<usize>,
    /// Clause marks: cell, cell its numbers are written in, the numbers, their colour.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    cl: Vec<(usize, usize, String, String)>,
    /// The instruction tree ([`PanelJson::trees`]).
    tr: usize,
    /// The probabilities of the environment's actions.
    p: Vec<f32>,
    /// The probability the policy gave actions the environment does not have (absent when it
    /// has them all).
    #[serde(skip_serializing_if = "Option::is_none")]
    po: Option<f32>,
    /// The action taken.
    a: usize,
    /// What minigrid's bot would do here.
    ex: Option<usize>,
    /// The bot's plan (absent where empty).
    #[serde(skip_serializing_if = "String::is_empty")]
    plan: String,
    /// Critic value and reward, rounded for display.
    v: f64,
    r: f64,
    /// The maps, for a model with maps.
    #[serde(skip_serializing_if = "Option::is_none")]
    att: Option<MapsJson>,
}

/// One step's maps and what is drawn with them.
#[derive(Debug, Serialize)]
struct MapsJson {
    /// The shared scale's upper end (0 is the lower).
    s: f32,
    /// `M`, in [`MAP_LEVELS`] of `s`, by view cell.
    m: Vec<u16>,
    /// Each word's map, likewise.
    wd: Vec<Vec<u16>>,
    /// Each word's weight w, as the trace holds it, and entropy H (nats, rounded).
    w: Vec<f32>,
    h: Vec<f64>,
    /// The world cell under each view cell (`-1` outside the grid) and how a map is drawn
    /// there: `T` tinted floor, `R` ring, `I` a door's inset ring, `-` nothing.
    cells: Vec<i64>,
    marks: String,
    /// Grounding marks: the map (`-1` for `M`, else the word's index), view cell, colour.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    hits: Vec<(i64, usize, usize, String)>,
    /// The step's accuracies, one line per kind, or why a kind is not scored.
    acc: String,
}

/// The cell number of `pos` on a grid `width` wide.
fn cell(pos: Pos, width: usize) -> usize {
    pos.1.max(0) as usize * width + pos.0.max(0) as usize
}

/// Who acted, as `replay` names it.
pub(super) fn title(trace: &EpisodeTrace) -> String {
    match &trace.model_name {
        Some(n) => n.clone(),
        None => format!("{} ({})", trace.checkpoint, trace.variant.name()),
    }
}

/// The panel of `trace`, its tiles added to `atlas`; scenes are computed a block at a time
/// ([`for_each_block`]), so memory holds the page's data, not the episode's pictures.
pub(super) fn panel(
    trace: &EpisodeTrace,
    alpha: f64,
    atlas: &mut Atlas,
    stop: Option<&StopFlag>,
) -> Result<PanelJson, RecordError> {
    let first = trace.steps.first().map_or(&trace.final_world, |s| &s.world);
    let (width, height) = (first.grid.width(), first.grid.height());
    // The bars follow the environment's action space, not the policy's head: Dynamic-Obstacles
    // has three actions, and the mass a policy puts on the others is shown as one figure.
    let n_actions = first
        .rules
        .as_ref()
        .map_or(Action::COUNT, Rules::num_actions)
        .min(Action::COUNT);
    let words: Vec<String> = trace
        .steps
        .iter()
        .find_map(|s| s.attention.as_ref())
        .map(|a| a.words.iter().map(|w| w.word.clone()).collect())
        .unwrap_or_default();
    let mut out = PanelJson {
        title: title(trace),
        level: trace.level.to_string(),
        seed: trace.seed,
        mode: trace.mode.name(),
        mission: trace.mission.clone(),
        success: trace.success(),
        total_reward: trace.total_reward(),
        width,
        height,
        actions: action_names()[..n_actions].to_vec(),
        words,
        expert: trace
            .steps
            .iter()
            .any(|s| s.expert_action.is_some() || !s.expert_plan.is_empty()),
        grids: Vec::new(),
        trees: Vec::new(),
        steps: Vec::with_capacity(trace.steps.len()),
    };
    let mut tree_ids: HashMap<String, usize> = HashMap::new();
    for_each_block(trace, alpha, |start, scenes| {
        if stopped(stop) {
            return Err(RecordError::Interrupted);
        }
        for (k, scene) in scenes.iter().enumerate() {
            let step = &trace.steps[start + k];
            let grid = grid_tiles(&step.world, atlas);
            if out.grids.last() != Some(&grid) {
                out.grids.push(grid);
            }
            let tree = tree_html(&scene.tree);
            let tr = if let Some(&i) = tree_ids.get(&tree) {
                i
            } else {
                out.trees.push(tree.clone());
                tree_ids.insert(tree, out.trees.len() - 1);
                out.trees.len() - 1
            };
            let g = out.grids.len() - 1;
            out.steps
                .push(step_json(step, scene, g, tr, n_actions, width, atlas));
        }
        Ok(())
    })?;
    Ok(out)
}

/// The tiles of `world`'s grid, without the agent.
fn grid_tiles(world: &World, atlas: &mut Atlas) -> GridJson {
    let (w, h) = (world.grid.width(), world.grid.height());
    let mut grid = GridJson {
        unlit: Vec::with_capacity(w * h),
        lit: Vec::with_capacity(w * h),
    };
    for y in 0..h {
        for x in 0..w {
            let o = world.grid.get((x as i32, y as i32));
            grid.unlit.push(atlas.id(Tile::cell(o, None, false)));
            grid.lit.push(atlas.id(Tile::cell(o, None, true)));
        }
    }
    grid
}

/// One step's data.
fn step_json(
    step: &StepRecord,
    scene: &StepScene,
    g: usize,
    tr: usize,
    n_actions: usize,
    width: usize,
    atlas: &mut Atlas,
) -> StepJson {
    let world = &step.world;
    let seen = visible_cells(world);
    let agent_lit = seen.contains(&world.agent_pos);
    let at = atlas.id(Tile::cell(
        world.grid.get(world.agent_pos),
        Some(world.agent_dir),
        agent_lit,
    ));
    let other: f32 = step.probs[n_actions..].iter().sum();
    StepJson {
        g,
        ag: [
            world.agent_pos.0,
            world.agent_pos.1,
            i32::from(world.agent_dir),
        ],
        at,
        vis: seen.iter().map(|&p| cell(p, width)).collect(),
        view: atlas.view(&step.obs),
        tg: pending_target_cells(world)
            .into_iter()
            .map(|p| cell(p, width))
            .collect(),
        cl: scene
            .clauses
            .iter()
            .map(|m| {
                (
                    cell(m.pos, width),
                    cell(m.label_at, width),
                    m.label.clone(),
                    hex(stage_color(m.stage)),
                )
            })
            .collect(),
        tr,
        p: step.probs[..n_actions].to_vec(),
        po: (n_actions < Action::COUNT).then_some(other),
        a: step.action as usize,
        ex: step.expert_action.map(|a| a as usize),
        plan: step.expert_plan.clone(),
        v: rounded(step.value),
        r: (step.reward * 1000.0).round() / 1000.0,
        att: maps_json(step, scene, width),
    }
}

/// `x` to three decimals, as the page shows it.
fn rounded(x: f32) -> f64 {
    (f64::from(x) * 1000.0).round() / 1000.0
}

/// `map` in [`MAP_LEVELS`] of `hi`, by view cell.
fn quantized(map: &ViewMap, hi: f32) -> Vec<u16> {
    map.iter()
        .flatten()
        .map(|&v| ((v / hi).clamp(0.0, 1.0) * MAP_LEVELS).round() as u16)
        .collect()
}

/// The maps of a step of a model with maps.
fn maps_json(step: &StepRecord, scene: &StepScene, width: usize) -> Option<MapsJson> {
    let att = step.attention.as_ref()?;
    let hi = scene.scale_max;
    let (cells, marks) = overlay_cells(&step.world, width);
    let hits: Vec<(i64, usize, usize, String)> = scene
        .grounding
        .iter()
        .flat_map(|g| {
            let which = g.word.map_or(-1, |i| i as i64);
            g.hits
                .iter()
                .map(move |h| (which, h.cell.0, h.cell.1, hex(hit_color(h))))
        })
        .collect();
    Some(MapsJson {
        s: hi,
        m: quantized(&att.combined, hi),
        wd: att.words.iter().map(|w| quantized(&w.map, hi)).collect(),
        w: att.words.iter().map(|w| w.weight).collect(),
        h: att.words.iter().map(|w| rounded(w.entropy)).collect(),
        cells,
        marks,
        hits,
        acc: accuracy_text(step, scene),
    })
}

/// The world cell under each view cell and how a map is drawn there ([`MapsJson::cells`]).
/// [`map_cells`] holds the rule (which view cells fall on the grid, which are tinted and which
/// ringed); fed a map whose values are the view cells' own numbers, it gives the page both
/// without a second copy of the rule.
fn overlay_cells(world: &World, width: usize) -> (Vec<i64>, String) {
    let numbers: ViewMap =
        std::array::from_fn(|vy| std::array::from_fn(|vx| (vy * VIEW_SIZE + vx) as f32));
    let mut cells = vec![-1; VIEW_SIZE * VIEW_SIZE];
    let mut marks = vec!['-'; VIEW_SIZE * VIEW_SIZE];
    for (pos, i, mark) in map_cells(world, &numbers) {
        let i = i as usize;
        if let (Some(c), Some(m)) = (cells.get_mut(i), marks.get_mut(i)) {
            *c = cell(pos, width) as i64;
            *m = match mark {
                CellMark::Tint => 'T',
                CellMark::Ring => 'R',
                CellMark::Inset => 'I',
            };
        }
    }
    (cells, marks.into_iter().collect())
}

/// The step's accuracies as the debugger lists them: one line per kind of word shown, its
/// scores or why it is not scored.
fn accuracy_text(step: &StepRecord, scene: &StepScene) -> String {
    accuracy_rows(step, scene)
        .into_iter()
        .map(|(kind, row)| match row {
            Ok(g) => {
                let a = &g.accuracies;
                format!(
                    "{}: {} related · acc {:.2} · ng {:.2} · bs {:.2} · cmb {:.2} · pointing {:.2} (chance {:.2})",
                    kind.name(),
                    g.hits.len(),
                    a.acc,
                    a.acc_ng,
                    a.acc_bs,
                    a.acc_cmb,
                    a.pointing,
                    a.chance.pointing
                )
            }
            Err(reason) => reason,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The instruction tree as the debugger shows it: one row per sequence and clause, indented
/// by depth, its stage in the stage's colour, the clause waited on in bold, a done one struck
/// through, each clause's targets; then the doors.
fn tree_html(tree: &InstructionTree) -> String {
    let mut s = String::new();
    for n in &tree.nodes {
        let text = match n.clause {
            Some(c) => format!("{} · {}", c + 1, n.text),
            None => n.text.clone(),
        };
        let _ = write!(
            s,
            "<div class=\"node {}\" style=\"margin-left:{}px\"><span class=\"stage\" style=\"color:{}\">{}</span> <span class=\"text\">{}</span>",
            n.stage.name(),
            18 * n.depth,
            hex(stage_color(n.stage)),
            n.stage.name(),
            escape_html(&text)
        );
        if n.clause.is_some() {
            let _ = write!(
                s,
                " <span class=\"targets\">targets: {}</span>",
                escape_html(&targets_text(&n.targets))
            );
        }
        s.push_str("</div>");
    }
    if !tree.doors.is_empty() {
        let _ = write!(
            s,
            "<div class=\"doors\">doors: {}</div>",
            escape_html(&doors_text(&tree.doors))
        );
    }
    s
}
