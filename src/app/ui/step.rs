//! The step panel, in the centre: the mission and the step, then the maps (with Δ beside `M`
//! in the faithfulness view) so that they keep the space at every window size, then the
//! step's numbers side by side, the instruction tree and the faithfulness summary with its
//! probes.

use eframe::egui;

use crate::app::faithful::FaithfulnessView;
use crate::app::numbers::{
    MAPS_PER_ROW, accuracy_lines, map_side, maps_row, policy_bars, policy_header, weights_panel,
};
use crate::app::session::{Selection, Session, start_attention_probe};
use crate::app::tree::tree_ui;
use crate::env::roles::roles_of;
use crate::episode::{EpisodeTrace, StepRecord};
use crate::metrics::report::browse::read_only_line;
use crate::record::StepScene;

/// The step panel, with the faithfulness view's switch and its measures of the step.
pub(super) struct StepPanel {
    /// Show the faithfulness view (occlusion, interventions, probes).
    show_faithfulness: bool,
    /// The faithfulness measures of the step shown.
    faithfulness: FaithfulnessView,
}

impl StepPanel {
    /// The panel, with the faithfulness view shown from the start or not.
    pub(super) fn new(show_faithfulness: bool) -> Self {
        Self {
            show_faithfulness,
            faithfulness: FaithfulnessView::default(),
        }
    }

    /// Draws the step at the cursor.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        let Some(shown) = session.shown.clone() else {
            ui.label(if session.busy() {
                "running the episode…"
            } else {
                "no episode"
            });
            return;
        };
        let i = session.cursor.step.min(shown.len().saturating_sub(1));
        let (Some(step), Some(scene)) = (shown.trace.steps.get(i), shown.scene(i)) else {
            return;
        };
        let scene = &*scene;
        policy_header(ui, step, &shown);
        // The maps come first, under the mission: the tree, the doors and the numbers give
        // way to them, below, at any window size (the column scrolls).
        // The maps shown: the words' (less those folded), M's and Δ's; and the clause numbers
        // of a sequence between them.
        let roles = roles_of(&step.world);
        let words = step.attention.as_ref().map_or(0, |a| a.words.len());
        let with_roles = roles.len() == words && words > 0;
        let shown_words = session
            .selection
            .folded(&roles, words)
            .iter()
            .filter(|f| !**f)
            .count();
        // The accuracy lines go under the shorter column.
        let under_actions = shown_words > shown.trace.n_actions;
        // A Python policy's episode replayed from its report: what it computed was not
        // recorded, and there is no policy here to run for probes or the faithfulness view.
        if let Some(policy) = &session.read_only {
            ui.label(egui::RichText::new(read_only_line(policy)).strong())
                .on_hover_text(
                    "the report holds its actions, not its probabilities, values or maps: the world, the agent's view and minigrid's bot beside it are replayed step by step",
                );
            ui.separator();
            tree_ui(ui, &scene.tree);
            return;
        }
        // The bot has neither maps nor a network to probe: its plan (above) is what it
        // attends to.
        if session.agent_is_bot() {
            ui.label(
                "minigrid's bot acts from the world itself: no attention maps and no network to probe; its plan is shown above",
            );
            ui.separator();
            numbers(
                ui,
                &session.selection,
                step,
                &shown.trace,
                scene,
                under_actions,
            );
            tree_ui(ui, &scene.tree);
            return;
        }
        // A model without maps gets its occlusion saliency in their place, always.
        let mapless = step.attention.is_none();
        let faithful = self.show_faithfulness || mapless;
        let agent = session.agent.clone().filter(|_| faithful);
        if let Some(agent) = &agent {
            self.faithfulness
                .update(agent, &shown, i, session.generation);
        }
        let clauses = if with_roles {
            roles
                .iter()
                .filter_map(|r| r.clause)
                .max()
                .map_or(0, |m| m + 1)
        } else {
            0
        };
        let n_maps = shown_words + usize::from(words > 0) + usize::from(faithful);
        // Maps wrap into rows of at most this many: a long mission's maps stay on screen.
        let side = map_side(
            ui,
            n_maps.min(MAPS_PER_ROW),
            if clauses > 1 { clauses } else { 0 },
        );
        if mapless {
            ui.label(
                "no attention maps: the occlusion saliency below (how much the action distribution changes when a cell becomes floor) stands in for them",
            );
            ui.horizontal_top(|ui| {
                self.faithfulness
                    .occlusion_ui(ui, side, Some(&step.obs), true);
            });
        } else {
            // The boxes that change the maps come first: with a long mission unfolded into
            // two rows of maps they stay in the window.
            ui.horizontal(|ui| {
                ui.checkbox(
                    &mut self.show_faithfulness,
                    "faithfulness: does this step's behaviour depend on M?",
                );
                let mut fold = session.selection.folds(words);
                if ui
                    .checkbox(&mut fold, "fold function words")
                    .on_hover_text("the maps of words with no role in the grammar (go, to, the, then, …) as one line")
                    .changed()
                {
                    session.selection.fold_function_words = Some(fold);
                }
            });
            let faithfulness = &self.faithfulness;
            maps_row(&mut session.selection, ui, step, scene, side, |ui| {
                if faithful {
                    faithfulness.occlusion_ui(ui, side, Some(&step.obs), false);
                }
            });
        }
        ui.separator();
        numbers(
            ui,
            &session.selection,
            step,
            &shown.trace,
            scene,
            under_actions,
        );
        tree_ui(ui, &scene.tree);
        if let Some(agent) = agent {
            let combined = step.attention.as_ref().map(|a| &a.combined);
            let asked = self.faithfulness.summary_ui(ui, &agent, &shown, combined);
            if let Some(how) = asked {
                session
                    .jobs
                    .push(start_attention_probe(&agent, &shown, how, session.alpha));
            }
        }
    }
}

/// The action probabilities beside the word weights, the step's accuracies under the shorter
/// of the two (`under_actions`: under the actions); `step` is a step of `trace`.
fn numbers(
    ui: &mut egui::Ui,
    selection: &Selection,
    step: &StepRecord,
    trace: &EpisodeTrace,
    scene: &StepScene,
    under_actions: bool,
) {
    ui.horizontal_top(|ui| {
        ui.vertical(|ui| {
            ui.set_width(330.0);
            ui.label("action probabilities");
            policy_bars(ui, step, trace);
            if under_actions {
                ui.add_space(4.0);
                accuracy_lines(ui, step, scene);
            }
        });
        ui.vertical(|ui| {
            weights_panel(selection, ui, step);
            if !under_actions {
                ui.add_space(4.0);
                accuracy_lines(ui, step, scene);
            }
        });
    });
}
