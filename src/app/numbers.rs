//! What the step panel and the compare panel draw of a step: the mission, the step and its
//! outcome, the policy's numbers, every word's map, the combined map (with the occlusion map
//! Δ beside it when asked for), the colour bar they share, the word weights and the grounding
//! accuracies.

use eframe::egui;
use egui::{Color32, Sense, Vec2};

use super::maps::{MapLook, color_bar, color_bar_labelled, heat_map};
use super::session::{FOLD_ABOVE_WORDS, Overlay, Selection, Shown};
use super::tree::color32;
use crate::episode::{EpisodeTrace, StepRecord};
use crate::record::StepScene;
use crate::record::scene::{NEGLIGIBLE_WEIGHT, accuracy_rows, action_rows, map_scale_max};
use crate::render::palette;

/// The most maps in one row: more wrap to the next ([`maps_row`]).
pub(in crate::app) const MAPS_PER_ROW: usize = 9;

/// The height of nine weight bars: what a longer mission's bars scroll within.
const WEIGHT_BARS_HEIGHT: f32 = 200.0;

/// Side of one map in points, from the width there is for `panels` maps, a colour bar and
/// `clauses` clause numbers, so that a row of them ends inside the panel (a 9-word mission's
/// ten maps at 1280×900 included), and from the height left in view under the cursor, so
/// that a row of them ends above the episode plot.
pub(in crate::app) fn map_side(ui: &egui::Ui, panels: usize, clauses: usize) -> f32 {
    let panels = panels.max(1) as f32;
    // Each map's column is a little wider than the map (its frame), then the colour bar with
    // its caption, and a number before each clause of a sequence.
    let per_map = ui.spacing().item_spacing.x + MAP_FRAME;
    let gaps = per_map * panels + COLOUR_BAR_WIDTH + CLAUSE_NUMBER_WIDTH * clauses as f32;
    let by_width = (ui.available_width() - gaps) / panels;
    let by_height = ui.clip_rect().max.y - ui.cursor().min.y - ABOVE_MAPS;
    by_width.min(by_height).clamp(MIN_MAP_SIDE, 210.0)
}

/// What stands between the cursor where [`map_side`] is asked and a map's top: the row of
/// boxes (faithfulness, fold), a caption of two lines, and margins, in points.
const ABOVE_MAPS: f32 = 90.0;

/// What a map's column adds to its side (frame and margins), in points.
const MAP_FRAME: f32 = 10.0;

/// The colour bar and its caption beside `M`, in points.
const COLOUR_BAR_WIDTH: f32 = 100.0;

/// A clause's number before its words' maps, with its spacing, in points.
const CLAUSE_NUMBER_WIDTH: f32 = 24.0;

/// The smallest map side: 7 cells of about 13 points, readable at a glance; a row that cannot
/// hold its maps at this side wraps instead of shrinking them further.
pub(in crate::app) const MIN_MAP_SIDE: f32 = 90.0;

/// The maps: `M` first, `delta` (the faithfulness view's Δ column) right after it and the
/// colour bar they share, so they stay in view; then every word's map in a grid that
/// wraps, grouped by clause on a mission of several, function words folded into one line
/// when [`Selection::folds`] says so. A click on a map selects it for the overlay.
pub(in crate::app) fn maps_row(
    selection: &mut Selection,
    ui: &mut egui::Ui,
    step: &StepRecord,
    scene: &StepScene,
    side: f32,
    delta: impl FnOnce(&mut egui::Ui),
) {
    let Some(att) = &step.attention else {
        return;
    };
    let roles = crate::env::roles::roles_of(&step.world);
    // The recordings' rule: what folds here is what a recording of the step folds.
    let folds = selection.folded(&roles, att.words.len());
    let roles = (roles.len() == att.words.len()).then_some(roles);
    let clauses = roles
        .as_ref()
        .and_then(|r| r.iter().filter_map(|x| x.clause).max())
        .map_or(1, |m| m + 1);
    let own = selection.own_scale(step.world.rules.is_some());
    ui.horizontal_top(|ui| {
        ui.vertical(|ui| {
            ui.set_width(side);
            // Never broken inside a word, however narrow the map.
            let extend = egui::TextWrapMode::Extend;
            ui.add(egui::Label::new(egui::RichText::new("combined M").strong()).wrap_mode(extend));
            ui.add(egui::Label::new("sum of w·A").wrap_mode(extend));
            let hits = scene
                .hits_of(None)
                .map(|g| g.hits.as_slice())
                .unwrap_or_default();
            let look = MapLook {
                hi: map_hi(&att.combined, scene, own),
                side,
                selected: selection.overlay == Overlay::Combined,
                dimmed: false,
                obs: Some(&step.obs),
                hits,
            };
            let r = heat_map(ui, &att.combined, &look);
            // Named, so that a test (or a screen reader) finds where each map was drawn.
            r.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, "map of M"));
            if r.clicked() {
                selection.overlay = Overlay::Combined;
            }
        });
        delta(ui);
        ui.vertical(|ui| {
            if own {
                color_bar_labelled(
                    ui,
                    "max",
                    1.0,
                    side * 0.8,
                    "own scale:\neach map 0 to\nits largest value",
                );
            } else {
                color_bar(
                    ui,
                    scene.scale_max,
                    side * 0.8,
                    "shared scale:\nall word maps and M",
                );
            }
            let mut ticked = own;
            if ui
                .checkbox(&mut ticked, "own scale")
                .on_hover_text(
                    "each map, and the map on the world, coloured from 0 to its own largest value: a spread map is not washed out beside a peaked one; off, all maps share the step's scale",
                )
                .changed()
            {
                selection.own_scale = Some(ticked);
            }
        });
        // The words wrap within what is left of the row, never past its edge.
        let rest = ui.available_width();
        ui.vertical(|ui| {
            ui.set_max_width(rest);
            let mut folded = Vec::new();
            ui.horizontal_wrapped(|ui| {
                let mut clause = None;
                for (i, w) in att.words.iter().enumerate() {
                    let role = roles.as_ref().map(|r| r[i]);
                    if folds.get(i).copied().unwrap_or(false) {
                        folded.push(format!("{} {:.3}", w.word, w.weight));
                        continue;
                    }
                    let here = role.and_then(|r| r.clause);
                    if clauses > 1 && here.is_some() && here != clause {
                        clause = here;
                        ui.label(
                            egui::RichText::new(format!("{}", here.unwrap_or(0) + 1))
                                .strong()
                                .size(16.0),
                        )
                        .on_hover_text("the clause these words belong to");
                    }
                    word_map(selection, ui, step, scene, side, i);
                }
            });
            if !folded.is_empty() {
                ui.label(egui::RichText::new(format!("folded (w): {}", folded.join(" · "))).weak());
            }
        });
    });
}

/// The top of `map`'s colour scale: its own largest value with `own` scales, else the step's
/// shared one.
fn map_hi(map: &crate::policy::ViewMap, scene: &StepScene, own: bool) -> f32 {
    if own {
        map_scale_max(map)
    } else {
        scene.scale_max
    }
}

/// One word's map with its name, weight and entropy; a click selects it for the overlay.
fn word_map(
    selection: &mut Selection,
    ui: &mut egui::Ui,
    step: &StepRecord,
    scene: &StepScene,
    side: f32,
    i: usize,
) {
    let Some(att) = &step.attention else { return };
    let w = &att.words[i];
    // Asked for at its full size, so that a wrapping row moves a map that does not fit to
    // the next line instead of cutting it at the panel's edge.
    let size = egui::vec2(
        side,
        side + 3.0 * ui.text_style_height(&egui::TextStyle::Body),
    );
    ui.allocate_ui_with_layout(size, egui::Layout::top_down(egui::Align::Min), |ui| {
        ui.set_width(side);
        let dimmed = w.weight < NEGLIGIBLE_WEIGHT;
        let title = egui::RichText::new(&w.word).strong();
        ui.label(if dimmed { title.weak() } else { title });
        // A narrow map puts each figure on its own line: a caption never breaks inside one.
        let caption = if side >= 110.0 {
            format!("w {:.3} · H {:.2}", w.weight, w.entropy)
        } else {
            format!("w {:.3}\nH {:.2}", w.weight, w.entropy)
        };
        ui.add(egui::Label::new(caption).wrap_mode(egui::TextWrapMode::Extend));
        let hits = scene
            .hits_of(Some(i))
            .map(|g| g.hits.as_slice())
            .unwrap_or_default();
        let look = MapLook {
            hi: map_hi(
                &w.map,
                scene,
                selection.own_scale(step.world.rules.is_some()),
            ),
            side,
            selected: i == selection.word && selection.overlay == Overlay::Word,
            dimmed,
            obs: Some(&step.obs),
            hits,
        };
        let r = heat_map(ui, &w.map, &look);
        r.widget_info(|| {
            egui::WidgetInfo::labeled(egui::Role::Image, true, format!("map of {}", w.word))
        });
        if r.clicked() {
            selection.word = i;
            selection.overlay = Overlay::Word;
        }
        if dimmed {
            ui.label(egui::RichText::new("w < 0.005: not in M").small().weak());
        }
    });
}

/// The word weights as named bars, and each kind of grounding accuracy or why it is not
/// shown at this step.
pub(in crate::app) fn weights_panel(selection: &Selection, ui: &mut egui::Ui, step: &StepRecord) {
    let Some(att) = &step.attention else {
        return;
    };
    // Folded function words leave the bars too (their weights stand in the maps' fold).
    let folds = selection.folded(&crate::env::roles::roles_of(&step.world), att.words.len());
    let shown: Vec<usize> = (0..att.words.len())
        .filter(|&i| !folds.get(i).copied().unwrap_or(false))
        .collect();
    ui.label(if shown.len() < att.words.len() {
        "word weights w (function words folded)"
    } else {
        "word weights w"
    });
    let labels: Vec<String> = shown.iter().map(|&i| att.words[i].word.clone()).collect();
    let values: Vec<f32> = shown.iter().map(|&i| att.words[i].weight).collect();
    let selected = shown.iter().position(|&i| i == selection.word);
    if labels.len() > FOLD_ABOVE_WORDS {
        // A long mission unfolded: its bars scroll within nine rows' height, so that the
        // maps under them (M first) stay in the window.
        egui::ScrollArea::vertical()
            .id_salt("word weights")
            .max_height(WEIGHT_BARS_HEIGHT)
            .show(ui, |ui| bars(ui, &labels, &values, selected, None));
    } else {
        bars(ui, &labels, &values, selected, None);
    }
}

/// The step's grounding accuracies, one line per evaluated map, each with its pointing
/// game and mass beside chance; a reason where a map is not scored.
pub(in crate::app) fn accuracy_lines(ui: &mut egui::Ui, step: &StepRecord, scene: &StepScene) {
    for (kind, row) in accuracy_rows(step, scene) {
        match row {
            Ok(g) => {
                let a = &g.accuracies;
                ui.label(format!(
                    "{}: {} related · acc {:.2} · ng {:.2} · bs {:.2} · cmb {:.2}",
                    kind.name(),
                    g.hits.len(),
                    a.acc,
                    a.acc_ng,
                    a.acc_bs,
                    a.acc_cmb
                ));
                // The pointing game and mass, each beside a uniform map's (chance).
                ui.label(
                    egui::RichText::new(format!(
                        "   pointing {:.2} (chance {:.2}) · mass {:.2} (chance {:.2})",
                        a.pointing, a.chance.pointing, a.mass, a.chance.mass
                    ))
                    .weak(),
                );
                if let (Some(r), Some(c)) = (a.region, a.region_chance) {
                    ui.label(
                        egui::RichText::new(format!(
                            "   region (the side it names, from the start pose) {r:.2} (chance {c:.2})"
                        ))
                        .weak(),
                    );
                }
            }
            Err(reason) => {
                ui.label(egui::RichText::new(reason).weak());
            }
        }
    }
}

/// The mission, the step and its outcome.
pub(in crate::app) fn policy_header(ui: &mut egui::Ui, step: &StepRecord, shown: &Shown) {
    ui.label(egui::RichText::new(&step.world.mission).heading());
    ui.label(step_line(step.t, shown));
    // The action and the bot's on one line: a long mission needs the height below.
    ui.horizontal_wrapped(|ui| {
        ui.label(format!(
            "action {} · value {:.3} · reward {:.3}",
            step.action.name(),
            step.value,
            step.reward
        ));
        expert_line(ui, step);
    });
    plan_line(ui, step);
}

/// What minigrid's bot would do here; a warning where the agent left it.
pub(in crate::app) fn expert_line(ui: &mut egui::Ui, step: &StepRecord) {
    match step.expert_action {
        Some(a) => {
            ui.label(format!("expert (minigrid's bot): {}", a.name()));
            if a != step.action {
                ui.colored_label(EXPERT_LEFT, "· left the expert's plan here");
            }
        }
        None => {
            ui.label("expert (minigrid's bot): none");
        }
    }
}

/// The bot's plan, its subgoals in order.
pub(in crate::app) fn plan_line(ui: &mut egui::Ui, step: &StepRecord) {
    // The debugger's font has no arrow: the plan's steps are joined by ">" here.
    let plan = step.expert_plan.replace('→', ">");
    ui.label(format!("plan: {plan}"));
}

/// The action probabilities as named bars, one per action the policy of `trace` scores (an
/// agent of three actions gets three), the chosen action highlighted.
pub(in crate::app) fn policy_bars(ui: &mut egui::Ui, step: &StepRecord, trace: &EpisodeTrace) {
    let (labels, values): (Vec<String>, Vec<f32>) = action_rows(trace.action_probs(step))
        .into_iter()
        .map(|(n, p)| (n.to_owned(), p))
        .unzip();
    bars(
        ui,
        &labels,
        &values,
        Some(step.action as usize),
        step.expert_action.map(|a| a as usize),
    );
}

/// [`policy_header`] and [`policy_bars`] (the compare panel).
pub(in crate::app) fn policy_panel(ui: &mut egui::Ui, step: &StepRecord, shown: &Shown) {
    policy_header(ui, step, shown);
    policy_bars(ui, step, &shown.trace);
}

/// `"step 4 of 0–12 · success · total reward 0.817"`: steps count from 0, so the range is
/// given rather than a count that the last step never reaches.
pub fn step_line(t: usize, shown: &Shown) -> String {
    if !shown.is_complete() {
        return format!(
            "step {t} of 0–{} so far · the episode is still running",
            shown.len().saturating_sub(1)
        );
    }
    format!(
        "step {t} of 0–{} · {} · total reward {:.3}",
        shown.len().saturating_sub(1),
        if shown.trace.success() {
            "success"
        } else {
            "failure"
        },
        shown.trace.total_reward()
    )
}

/// The colour of "left the expert's plan here", in the panel and on the episode plot.
pub(in crate::app) const EXPERT_LEFT: Color32 = Color32::from_rgb(230, 80, 80);

/// A failure, in the timeline's "failed: …" and the episodes panel: red, as a miss is.
pub(in crate::app) const FAILED: Color32 = Color32::from_rgb(230, 80, 80);

/// The chosen action's bar and the selected word's ([`palette::CHOSEN_BAR`]).
pub(in crate::app) const HIGHLIGHT: Color32 = color32(palette::CHOSEN_BAR);

/// Horizontal bars with labels and values; `highlight` is drawn in another colour and
/// `expert` (minigrid's bot's action) is marked "< expert".
fn bars(
    ui: &mut egui::Ui,
    labels: &[String],
    values: &[f32],
    highlight: Option<usize>,
    expert: Option<usize>,
) {
    let width = ui.available_width().min(340.0);
    for (i, (l, &v)) in labels.iter().zip(values).enumerate() {
        ui.horizontal(|ui| {
            ui.add_sized([64.0, 16.0], egui::Label::new(l.as_str()).truncate());
            let (rect, _) = ui.allocate_exact_size(Vec2::new(width - 120.0, 14.0), Sense::hover());
            let p = ui.painter_at(rect);
            p.rect_filled(rect, 2.0, ui.visuals().extreme_bg_color);
            let mut bar = rect;
            bar.set_width(rect.width() * v.clamp(0.0, 1.0));
            let color = if highlight == Some(i) {
                HIGHLIGHT
            } else {
                color32(palette::BAR)
            };
            p.rect_filled(bar, 2.0, color);
            if expert == Some(i) {
                ui.label(format!("{v:.3} < expert"));
            } else {
                ui.label(format!("{v:.3}"));
            }
        });
    }
}
