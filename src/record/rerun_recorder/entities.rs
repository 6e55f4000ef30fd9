//! What one recording logs: the static entities, and each step's images, maps, labels,
//! grounding points, policy outputs and faithfulness measures (the paths in the parent's
//! table).

use std::fmt::Write as _;

use rerun::RecordingStream;

use super::marks::{
    self, LANDMARKS, WORLD_MARKS, agent_marker, bar_frame, labelled_bars, log_landmarks,
};
use super::{RecordError, sdk, word_path};
use crate::env::Pos;
use crate::env::roles::roles_of;
use crate::env::tree::pending_target_cells;
use crate::episode::{EpisodeTrace, StepRecord};
use crate::metrics::faithfulness::peaks::peak_line;
use crate::metrics::grounding::{EvaluatedMap, WordKind};
use crate::policy::ViewMap;
use crate::record::RERUN_SDK_VERSION;
use crate::record::fold::folded_words;
use crate::record::scene::{
    NEGLIGIBLE_WEIGHT, StepScene, TILE_PX, accuracy_rows, action_label, action_rows,
    attention_rings, cell_centre, hit_color,
};

/// Where the world's legend is logged (static).
pub const WORLD_LEGEND: &str = "world/legend";

/// What the world picture's marks mean.
pub const WORLD_LEGEND_TEXT: &str = "**magenta corners**: the targets waited on · **numbers**: \
    each clause's targets (magenta waited on, grey done, blue later) · **line**: the agent's \
    trail · **floor tint and rings**: the map `M` · **bright cells**: what the agent sees";

pub(super) fn log_static(
    rec: &RecordingStream,
    first: &EpisodeTrace,
    n: usize,
) -> Result<(), RecordError> {
    let meta = format!(
        "# groundscope recording\n\n\
         | | |\n|---|---|\n\
         | groundscope | {} |\n| Rerun SDK | {RERUN_SDK_VERSION} |\n\
         | checkpoint | {} |\n| model | {} |\n| level | {} |\n| episodes | {n} (seeds from {}) |\n| actions | {} |\n",
        env!("CARGO_PKG_VERSION"),
        first.checkpoint,
        first.variant.name(),
        first.level,
        first.seed,
        first.mode.name(),
    );
    rec.log_static("meta", &rerun::TextDocument::from_markdown(meta))
        .map_err(sdk)?;
    if n == 1 {
        rec.log_static("mission", &rerun::TextDocument::new(first.mission.as_str()))
            .map_err(sdk)?;
    }
    // The overlay has one pixel per world cell; scaling it by the tile size lays it over the
    // world render.
    let s = TILE_PX as f32;
    rec.log_static(
        "world/attention",
        &rerun::Transform3D::from_scale((s, s, 1.0)),
    )
    .map_err(sdk)?;
    rec.log_static(WORLD_MARKS, &rerun::Transform3D::from_scale((s, s, 1.0)))
        .map_err(sdk)?;
    // The world's legend as text beside the picture: as the view's title it was cut to
    // "world (magenta: targ…" in any panel narrower than it.
    rec.log_static(
        WORLD_LEGEND,
        &rerun::TextDocument::from_markdown(WORLD_LEGEND_TEXT),
    )
    .map_err(sdk)?;
    // One row per action the policy scores: an agent of 3 actions gets a frame of 3.
    rec.log_static("policy/probs/frame", &bar_frame(first.n_actions))
        .map_err(sdk)?;
    if first.variant.name() == "attention" {
        rec.log_static(format!("{LANDMARKS}/agent"), &agent_marker())
            .map_err(sdk)?;
    }
    rec.log_static(
        "policy/value",
        &rerun::SeriesLines::new()
            .with_names(["value"])
            .with_colors([[31, 119, 180]]),
    )
    .map_err(sdk)?;
    rec.log_static(
        "policy/reward",
        &rerun::SeriesLines::new()
            .with_names(["reward"])
            .with_colors([[44, 160, 44]]),
    )
    .map_err(sdk)?;
    for kind in WordKind::ALL {
        rec.log_static(
            format!("metrics/{}", kind.name()),
            &rerun::SeriesPoints::new().with_names(
                crate::metrics::grounding::Accuracies::NAMES
                    .map(|a| format!("{} {a}", kind.name())),
            ),
        )
        .map_err(sdk)?;
    }
    Ok(())
}

/// A 7×7 map as a colour-mapped depth image on `[0, hi]`: viridis, or greyscale for a word
/// whose weight is (nearly) 0, so that it reads as left out of `M`.
fn map_image(map: &ViewMap, hi: f32, grey: bool) -> rerun::DepthImage {
    let bytes: Vec<u8> = map.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    let colormap = if grey {
        rerun::components::Colormap::Grayscale
    } else {
        rerun::components::Colormap::Viridis
    };
    rerun::DepthImage::from_data_type_and_bytes(bytes, [7, 7], rerun::ChannelDatatype::F32)
        .with_colormap(colormap)
        .with_depth_range([0.0, f64::from(hi)])
}

/// Hit/miss markers at the related objects: green when the map is at or above the threshold
/// on the object's cell (`acc`), yellow when only next to it (`acc_ng` or `acc_bs`), red for
/// a miss.
fn grounding_points(g: &EvaluatedMap) -> rerun::Points2D {
    let colors: Vec<[u8; 3]> = g.hits.iter().map(hit_color).collect();
    let labels: Vec<String> = g
        .hits
        .iter()
        .map(|h| {
            let m = |b: bool| if b { "hit" } else { "miss" };
            format!(
                "{} acc {} · ng {} · bs {} · cmb {}",
                g.kind.name(),
                m(h.acc),
                m(h.acc_ng),
                m(h.acc_bs),
                m(h.acc_cmb)
            )
        })
        .collect();
    rerun::Points2D::new(g.hits.iter().map(|h| cell_centre(h.cell)))
        .with_colors(colors)
        .with_radii([0.22])
        .with_labels(labels)
        .with_show_labels(false)
}

/// An invisible point under a map: Rerun fits a 2-D view to its contents but not to their
/// labels, and a map's label is drawn under the map, so without it a view sized to the map
/// would cut the label off.
/// An invisible point under a map that keeps its label (two lines when the view is narrow)
/// inside the view.
fn label_room() -> rerun::Points2D {
    rerun::Points2D::new([(3.5, 9.6)])
        .with_radii([0.001])
        .with_colors([[0, 0, 0]])
}

fn label_box(text: String) -> rerun::Boxes2D {
    rerun::Boxes2D::from_mins_and_sizes([(0.0, 0.0)], [(7.0, 7.0)])
        .with_labels([text])
        .with_show_labels(true)
        .with_colors([[255, 255, 255]])
}

/// Occlusion Δ as a depth image beside the maps (on [0, 1], the range of a total-variation
/// distance) and ρ and the intervention effects as scalars.
fn log_faithfulness(
    rec: &RecordingStream,
    f: &crate::episode::StepFaithfulness,
    combined: Option<&ViewMap>,
) -> Result<(), RecordError> {
    let mut summary = match f.rank_correlation {
        Some(r) => format!("Spearman ρ(M, Δ) = {r:.3}"),
        None => "ρ(M, Δ): undefined".to_owned(),
    };
    if let Some(m) = combined {
        let _ = write!(summary, " · {}", peak_line(m, &f.occlusion));
    }
    summary.push_str("\n\n| one step with M changed | TV | best action |\n|---|---|---|\n");
    for (name, e) in &f.interventions {
        let _ = writeln!(
            summary,
            "| {name} | {:.3} | {} |",
            e.tv,
            if e.flip { "flips" } else { "kept" }
        );
    }
    rec.log(
        "faithfulness/summary",
        &rerun::TextDocument::from_markdown(summary),
    )
    .map_err(sdk)?;
    rec.log(
        "faithfulness/occlusion",
        &map_image(&f.occlusion, 1.0, false),
    )
    .map_err(sdk)?;
    if let Some(rho) = f.rank_correlation {
        rec.log(
            "faithfulness/rank_correlation",
            &rerun::Scalars::single(rho),
        )
        .map_err(sdk)?;
    }
    for (name, e) in &f.interventions {
        rec.log(
            format!("faithfulness/interventions/{name}"),
            &rerun::Scalars::single(e.tv),
        )
        .map_err(sdk)?;
    }
    Ok(())
}

/// Logs named bars at `path` (the labels), `path/tracks` and `path/bars`.
fn log_bars(
    rec: &RecordingStream,
    path: &str,
    rows: &[(String, f32)],
    full: f32,
    highlight: Option<usize>,
) -> Result<(), RecordError> {
    let chart = labelled_bars(rows, full, highlight);
    rec.log(path, &chart.labels).map_err(sdk)?;
    rec.log(format!("{path}/tracks"), &chart.tracks)
        .map_err(sdk)?;
    rec.log(format!("{path}/bars"), &chart.bars).map_err(sdk)
}

/// The world's marks at step `k`: the targets, the clauses' targets and the instruction tree
/// (when they changed since `prev`, the step before's scene), and the agent's path so far.
fn log_world_marks(
    rec: &RecordingStream,
    ep: &EpisodeTrace,
    k: usize,
    scene: &StepScene,
    prev: Option<&StepScene>,
) -> Result<(), RecordError> {
    let Some(step) = ep.steps.get(k) else {
        return Ok(());
    };
    rec.log(
        format!("{WORLD_MARKS}/targets"),
        &marks::targets(&pending_target_cells(&step.world)),
    )
    .map_err(sdk)?;
    // The tree changes only when a clause is done or an object moves: logged then, so a
    // recording stays the size it was for one-clause missions.
    let tree = &scene.tree;
    if prev.is_none_or(|p| p.tree != *tree) {
        rec.log(
            "mission/tree",
            &rerun::TextDocument::from_markdown(tree.markdown()),
        )
        .map_err(sdk)?;
    }
    // Where the numbers are written moves when an object comes to stand in a label's cell.
    if prev.is_none_or(|p| p.clauses != scene.clauses) {
        let (frames, labels) = marks::clause_targets(&scene.clauses, TILE_PX as f32);
        rec.log("world/clauses", &frames).map_err(sdk)?;
        rec.log("world/clauses/numbers", &labels).map_err(sdk)?;
    }
    let mut path: Vec<Pos> = Vec::with_capacity(k + 1);
    for s in ep.steps.iter().take(k + 1) {
        if path.last() != Some(&s.world.agent_pos) {
            path.push(s.world.agent_pos);
        }
    }
    rec.log(format!("{WORLD_MARKS}/trail"), &marks::trail(&path))
        .map_err(sdk)
}

/// Whether the agent did not take the expert's action at `step`.
fn left_expert(step: &crate::episode::StepRecord) -> bool {
    step.expert_action.is_some_and(|a| a != step.action)
}

/// The status panel's line on the expert (minigrid's bot beside the agent).
fn expert_line(step: &crate::episode::StepRecord) -> String {
    match step.expert_action {
        None => format!("expert (minigrid's bot): {}", step.expert_plan),
        Some(a) => format!(
            "expert (minigrid's bot) **{}**{} · plan: {}",
            a.name(),
            if a == step.action {
                ""
            } else {
                " — **left the expert's plan here**"
            },
            step.expert_plan
        ),
    }
}

pub(super) fn log_step(
    rec: &RecordingStream,
    ep: &EpisodeTrace,
    episode: usize,
    k: usize,
    scene: &StepScene,
    prev: Option<&StepScene>,
) -> Result<(), RecordError> {
    let Some(step) = ep.steps.get(k) else {
        return Ok(());
    };
    let (w, h) = scene.world.dimensions();
    rec.log(
        "world/grid",
        &rerun::Image::from_rgb24(scene.world.as_raw().as_slice(), [w, h]),
    )
    .map_err(sdk)?;
    let (vw, vh) = scene.view.dimensions();
    rec.log(
        "view/image",
        &rerun::Image::from_rgb24(scene.view.as_raw().as_slice(), [vw, vh]),
    )
    .map_err(sdk)?;

    log_world_marks(rec, ep, k, scene, prev)?;
    if let Some(f) = &step.faithfulness {
        log_faithfulness(rec, f, step.attention.as_ref().map(|a| &a.combined))?;
    }
    let rows = action_rows(ep.action_probs(step));
    let probs: Vec<(String, f32)> = rows
        .iter()
        .map(|(n, p)| (format!("{n} {p:.3}"), *p))
        .collect();
    log_bars(rec, "policy/probs", &probs, 1.0, Some(step.action as usize))?;
    rec.log(
        "policy/value",
        &rerun::Scalars::single(f64::from(step.value)),
    )
    .map_err(sdk)?;
    rec.log("policy/reward", &rerun::Scalars::single(step.reward))
        .map_err(sdk)?;
    rec.log(
        "policy/action",
        &rerun::TextLog::new(format!(
            "episode {episode} step {}: {} (value {:.3}, reward {:.3})",
            step.t,
            action_label(step),
            step.value,
            step.reward
        )),
    )
    .map_err(sdk)?;
    let mut status = format!(
        "**{}**\n\nepisode {episode} (seed {}) · step {} of {} · {}\n\n\
         action **{}** · value {:.3} · reward {:.3}\n\n{}\n\n| action | p |\n|---|---|\n",
        ep.mission,
        ep.seed,
        step.t,
        ep.steps.len(),
        if ep.success() { "success" } else { "failure" },
        action_label(step),
        step.value,
        step.reward,
        expert_line(step),
    );
    for (i, (n, p)) in rows.iter().enumerate() {
        let mut mark = if i == step.action as usize {
            " ◀".to_string()
        } else {
            String::new()
        };
        if step.expert_action.is_some_and(|a| a as usize == i) {
            mark += " ★ expert";
        }
        let _ = writeln!(status, "| {i} {n} | {p:.3}{mark} |");
    }
    rec.log(
        "policy/expert",
        &rerun::TextLog::new(format!(
            "episode {episode} step {}: expert {} · plan {}{}",
            step.t,
            step.expert_action.map_or("(gave up)", |a| a.name()),
            step.expert_plan,
            if left_expert(step) {
                " · LEFT THE EXPERT'S PLAN HERE"
            } else {
                ""
            },
        )),
    )
    .map_err(sdk)?;
    rec.log("policy/status", &rerun::TextDocument::from_markdown(status))
        .map_err(sdk)?;

    let Some(att) = &step.attention else {
        return Ok(());
    };
    let hi = scene.scale_max;
    log_landmarks(rec, &step.obs)?;
    let legend = log_word_maps(rec, step, att, scene)?;
    rec.log("attention/combined", &map_image(&att.combined, hi, false))
        .map_err(sdk)?;
    rec.log(
        "attention/combined/label",
        &label_box(format!("M · shared scale 0–{hi:.2}")),
    )
    .map_err(sdk)?;
    rec.log("attention/combined/pad", &label_room())
        .map_err(sdk)?;
    log_grounding(rec, "attention/combined/grounding", scene.hits_of(None))?;
    rec.log("attention/colorbar", &marks::colorbar(hi))
        .map_err(sdk)?;
    rec.log(
        "attention/colorbar/label",
        &rerun::Boxes2D::from_mins_and_sizes([(0.0, 0.0)], [(1.0, 32.0)])
            .with_labels([format!("0–{hi:.3}: all word maps and M")])
            .with_show_labels(true)
            .with_colors([[255, 255, 255]]),
    )
    .map_err(sdk)?;
    let weights: Vec<(String, f32)> = att
        .words
        .iter()
        .map(|w| {
            (
                format!("{} · w {:.2} · H {:.2}", w.word, w.weight, w.entropy),
                w.weight,
            )
        })
        .collect();
    log_bars(rec, "attention/weights", &weights, 1.0, None)?;
    rec.log("attention/weights/frame", &bar_frame(weights.len()))
        .map_err(sdk)?;
    // H is at most ln 49 nats (a uniform map over the 49 cells).
    let entropies: Vec<(String, f32)> = att
        .words
        .iter()
        .map(|w| (format!("{} · H {:.2}", w.word, w.entropy), w.entropy))
        .collect();
    log_bars(rec, "attention/entropy", &entropies, 49f32.ln(), None)?;
    rec.log("attention/entropy/frame", &bar_frame(entropies.len()))
        .map_err(sdk)?;
    rec.log(
        "attention/legend",
        &rerun::TextDocument::from_markdown(legend),
    )
    .map_err(sdk)?;
    if let Some(overlay) = &scene.overlay {
        let (ow, oh) = overlay.dimensions();
        rec.log(
            "world/attention",
            &rerun::Image::from_rgba32(overlay.as_raw().as_slice(), [ow, oh]).with_draw_order(10.0),
        )
        .map_err(sdk)?;
        rec.log(
            "world/attention/rings",
            &marks::rings(&attention_rings(&step.world, &att.combined, hi)),
        )
        .map_err(sdk)?;
    }
    log_grounding_table(rec, step, scene)?;
    for g in &scene.grounding {
        rec.log(
            format!("metrics/{}", g.kind.name()),
            &rerun::Scalars::new(g.accuracies.values()),
        )
        .map_err(sdk)?;
    }
    Ok(())
}

/// Logs every word's map, label and grounding marks, a word the debugger folds under its own
/// path ([`word_path`]); returns the words table (word, w, H), which marks the folded ones.
fn log_word_maps(
    rec: &RecordingStream,
    step: &StepRecord,
    att: &crate::policy::AttentionTrace,
    scene: &StepScene,
) -> Result<String, RecordError> {
    let hi = scene.scale_max;
    let mut legend = String::from("| word | w | H |\n|---|---:|---:|\n");
    // The debugger's rule, on this step's mission: a folded word's map is kept, under a
    // path whose view the layout hides.
    let folded = folded_words(&roles_of(&step.world), att.words.len(), None);
    for (i, wa) in att.words.iter().enumerate() {
        let fold = folded.get(i).copied().unwrap_or(false);
        let path = word_path(i, &wa.word, fold);
        let grey = wa.weight < NEGLIGIBLE_WEIGHT;
        rec.log(path.as_str(), &map_image(&wa.map, hi, grey))
            .map_err(sdk)?;
        // Short, so that it fits under the map (the word is the view's title; the scale is
        // on M's label and the bar); a narrow view wraps it onto a second line.
        let note = if grey { " · not in M" } else { "" };
        rec.log(
            format!("{path}/label"),
            &label_box(format!("w {:.2} · H {:.2}{note}", wa.weight, wa.entropy)),
        )
        .map_err(sdk)?;
        rec.log(format!("{path}/pad"), &label_room()).map_err(sdk)?;
        log_grounding(rec, &format!("{path}/grounding"), scene.hits_of(Some(i)))?;
        let _ = writeln!(
            legend,
            "| {}{} | {:.3} | {:.2} |",
            wa.word,
            if fold { " (folded)" } else { "" },
            wa.weight,
            wa.entropy
        );
    }
    Ok(legend)
}

/// Logs the markers of a map, or clears them when the map was not evaluated at this step.
fn log_grounding(
    rec: &RecordingStream,
    path: &str,
    g: Option<&EvaluatedMap>,
) -> Result<(), RecordError> {
    match g {
        Some(g) => rec.log(path, &grounding_points(g)),
        None => rec.log(path, &rerun::Clear::flat()),
    }
    .map_err(sdk)
}

/// The step's grounding accuracies as a table, with the reason for each kind not scored
/// (a plot's legend would cover its points; a table has none).
fn log_grounding_table(
    rec: &RecordingStream,
    step: &StepRecord,
    scene: &StepScene,
) -> Result<(), RecordError> {
    let mut doc =
        String::from("| map | related | acc | ng | bs | cmb |\n|---|---:|---:|---:|---:|---:|\n");
    let mut missing = String::new();
    for (kind, row) in accuracy_rows(step, scene) {
        match row {
            Ok(g) => {
                let a = &g.accuracies;
                let _ = writeln!(
                    doc,
                    "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} |",
                    kind.name(),
                    g.hits.len(),
                    a.acc,
                    a.acc_ng,
                    a.acc_bs,
                    a.acc_cmb
                );
            }
            Err(reason) => {
                let _ = writeln!(missing, "\n- {reason}");
            }
        }
    }
    doc.push_str(&missing);
    rec.log(
        "metrics/grounding",
        &rerun::TextDocument::from_markdown(doc),
    )
    .map_err(sdk)
}
