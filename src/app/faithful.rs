//! The debugger's faithfulness view for the current step: the occlusion map Δ beside `M`,
//! their rank correlation next to whether their peaks agree, whether each one-step
//! intervention flips the best action, and probes that re-run the episode with the attention
//! changed at every step.

use std::time::Instant;

use eframe::egui;

use super::maps::{MapLook, color_bar, heat_map};
use super::session::{Agent, Shown};
use crate::episode::StepFaithfulness;
use crate::metrics::faithfulness::episode::{Loop, word_position};
use crate::metrics::faithfulness::peaks::peak_line;
use crate::policy::ViewMap;

/// Why a step has no interventions on `M` to show (rather than a heading with nothing under
/// it): the model has no maps, or takes no override of them.
pub fn no_interventions(agent: &Agent) -> &'static str {
    if agent.acting().variant() == crate::policy::Variant::Attention {
        "no interventions on M: this model takes no override of M (combined_override, docs/onnx.md#interventions)"
    } else {
        "no interventions on M: this model outputs no attention maps (docs/onnx.md#outputs)"
    }
}

/// The measures of one step, computed when first shown and kept until the step or the
/// episode changes.
#[derive(Default)]
pub struct FaithfulnessView {
    /// Episode generation and step of `result`.
    key: Option<(u64, usize)>,
    result: Option<Result<(StepFaithfulness, f64), String>>,
}

impl FaithfulnessView {
    /// Computes the measures of step `k` of `shown` unless they are already there.
    pub fn update(&mut self, agent: &Agent, shown: &Shown, k: usize, generation: u64) {
        if self.key != Some((generation, k)) {
            let t0 = Instant::now();
            let r = crate::metrics::faithfulness::annotate_step(agent.acting(), &shown.trace, k)
                .map_err(|e| e.to_string());
            let ms = t0.elapsed().as_secs_f64() * 1000.0;
            self.result = Some(r.map(|f| (f, ms)));
            self.key = Some((generation, k));
        }
    }

    /// The occlusion map Δ as one column of the row of maps (on its own scale).
    pub fn occlusion_ui(
        &self,
        ui: &mut egui::Ui,
        side: f32,
        obs: Option<&crate::env::view::Observation>,
        own_bar: bool,
    ) {
        let Some(Ok((f, _))) = &self.result else {
            return;
        };
        let hi = f.occlusion.iter().flatten().fold(1e-6f32, |a, b| a.max(*b));
        ui.vertical(|ui| {
            ui.set_width(side);
            ui.label(egui::RichText::new("occlusion Δ").strong());
            ui.label(format!("scale 0–{hi:.3}"));
            // The step's walls and objects outlined and the unseen cells hatched, as on the
            // word maps, so the stand-in map reads the same way.
            let look = MapLook {
                hi,
                side,
                selected: false,
                dimmed: false,
                obs,
                hits: &[],
            };
            heat_map(ui, &f.occlusion, &look).on_hover_text(
                "how much the action distribution changes (total variation) when this cell alone becomes empty floor; its own scale",
            );
        });
        if own_bar {
            color_bar(ui, hi, side * 0.8, "Δ's own scale");
        }
    }

    /// ρ(M, Δ) with the peaks' agreement, the one-step interventions and whether they flip
    /// the best action, and the closed-loop probes; returns a probe the user asked for.
    pub fn summary_ui(
        &self,
        ui: &mut egui::Ui,
        agent: &Agent,
        shown: &Shown,
        combined: Option<&ViewMap>,
    ) -> Option<Loop> {
        match &self.result {
            Some(Ok((f, ms))) => {
                ui.horizontal_wrapped(|ui| {
                    // A model without maps has no M to rank Δ against.
                    if combined.is_some() {
                        ui.label(match f.rank_correlation {
                            Some(r) => format!("Spearman ρ(M, Δ) = {r:.3}"),
                            None => "ρ(M, Δ): undefined (M or Δ constant)".to_owned(),
                        });
                    }
                    if let Some(m) = combined {
                        ui.label(peak_line(m, &f.occlusion)).on_hover_text(
                            "ρ ranks all 48 cells; the top cells are where M and Δ matter",
                        );
                    }
                    ui.label(egui::RichText::new(format!("({ms:.0} ms)")).weak());
                });
                ui.horizontal_wrapped(|ui| {
                    if f.interventions.is_empty() {
                        ui.label(no_interventions(agent));
                    } else {
                        ui.label("one step with M changed:");
                    }
                    for (name, e) in &f.interventions {
                        ui.label(format!(
                            "{name}: TV {:.3} · {}",
                            e.tv,
                            if e.flip {
                                "best action flips"
                            } else {
                                "best action kept"
                            }
                        ));
                    }
                });
            }
            Some(Err(e)) => {
                ui.label(format!("faithfulness: {e}"));
            }
            None => {}
        }
        let mut probe = None;
        if shown.trace.variant.name() != "attention" || !agent.acting().takes_interventions() {
            return None;
        }
        ui.horizontal_wrapped(|ui| {
            ui.label("re-run the episode with, at every step:");
            if ui.button("M uniform").clicked() {
                probe = Some(Loop::Uniform);
            }
            if ui.button("M steered to a distractor").clicked() {
                probe = Some(Loop::Steered);
            }
            let first = shown.trace.steps.first();
            for (color, label) in [(true, "colour word w = 0"), (false, "object word w = 0")] {
                let at = first.and_then(|s| word_position(&s.world, &shown.trace.tokens, color));
                if ui
                    .add_enabled(at.is_some(), egui::Button::new(label))
                    .clicked()
                    && let Some(i) = at
                {
                    probe = Some(Loop::ZeroWord(i));
                }
            }
        });
        probe
    }
}
