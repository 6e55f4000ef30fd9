//! The bottom bar: the timeline (first, back, play, forward, last, the scrub slider, speed, the
//! next grounding miss, the failure and the decisive step, and why a failed episode failed),
//! then the jobs running with their progress and the last message.

use std::sync::atomic::Ordering;

use eframe::egui;
use egui::Color32;

use crate::app::numbers::FAILED;
use crate::app::session::{Session, failure_step, next_miss};

/// The bottom bar; all it shows is the session's.
pub(super) struct TimelinePanel;

impl TimelinePanel {
    /// Draws the timeline, then the jobs and the last message.
    #[expect(
        clippy::unused_self,
        reason = "every panel draws through `ui(&mut self, ui, session)`; this one keeps nothing of its own"
    )]
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, session: &mut Session) {
        ui.horizontal(|ui| timeline(ui, session));
        ui.horizontal(|ui| jobs_and_messages(ui, session));
    }
}

/// The step buttons, the slider, the speed and the episode's own steps to go to.
fn timeline(ui: &mut egui::Ui, session: &mut Session) {
    let len = session.len();
    let cursor = &mut session.cursor;
    if ui.button("|<").on_hover_text("first step (Home)").clicked() {
        cursor.step = 0;
    }
    if ui.button("<").on_hover_text("step back (←)").clicked() {
        cursor.nudge(-1, len);
    }
    let play = if cursor.playing { "pause" } else { "play" };
    if ui
        .button(play)
        .on_hover_text("play / pause (space)")
        .clicked()
    {
        cursor.playing = !cursor.playing;
    }
    if ui.button(">").on_hover_text("step forward (→)").clicked() {
        cursor.nudge(1, len);
    }
    if ui.button(">|").on_hover_text("last step (End)").clicked() {
        cursor.step = len.saturating_sub(1);
    }
    let mut s = cursor.step;
    ui.add(
        egui::Slider::new(&mut s, 0..=len.saturating_sub(1))
            .text(format!("of 0–{}", len.saturating_sub(1))),
    );
    cursor.step = s;
    ui.add(egui::Slider::new(&mut cursor.speed, 0.5..=20.0).text("steps/s"));
    let Some(shown) = session.shown.clone() else {
        return;
    };
    if ui.button("next grounding miss").clicked() {
        match next_miss(&shown, session.cursor.step) {
            Some(i) => session.cursor.step = i,
            None => session.info("no grounding miss in this episode"),
        }
    }
    let fail = failure_step(&shown.trace).filter(|_| shown.is_complete());
    if ui
        .add_enabled(fail.is_some(), egui::Button::new("failure"))
        .clicked()
        && let Some(i) = fail
    {
        session.cursor.step = i;
    }
    // Where it was lost: the step `eval`'s report opens it at
    // (docs/evaluation.md#the-decisive-step).
    if let Some(i) = shown.decisive
        && ui
            .button(format!("decisive step {i}"))
            .on_hover_text(
                "where the episode was lost: the act its MiniGrid class or its behaviour names, \
                 else the first step it left the bot's plan at a cost, else its last",
            )
            .clicked()
    {
        session.cursor.step = i;
    }
    // Why it failed: the class and behaviour `eval` gives the same episode
    // (docs/evaluation.md#failure-classes); a MiniGrid class in its own terms ("stepped
    // into lava").
    if let Some(d) = &shown.failure {
        let behaviour = d
            .behaviour
            .map_or_else(String::new, |b| format!(" · {}", b.name()));
        ui.label(
            egui::RichText::new(format!("failed: {}{behaviour}", d.class.shown())).color(FAILED),
        )
        .on_hover_text(format!(
            "class {}; behaviour {}; target in view at {} step(s); M on it at {}",
            d.class.name(),
            d.behaviour.map_or("none", |b| b.name()),
            d.target_visible_steps,
            d.m_on_target_steps
                .map_or_else(|| "– (no M)".to_owned(), |n| n.to_string())
        ));
    }
}

/// A spinner and progress per job, "cancel", and the last message (an error in red).
fn jobs_and_messages(ui: &mut egui::Ui, session: &Session) {
    for job in &session.jobs {
        ui.spinner();
        if job.total > 0 {
            let d = job.done.load(Ordering::Relaxed);
            ui.add(
                egui::ProgressBar::new(d as f32 / job.total as f32)
                    .desired_width(160.0)
                    .text(format!("{} {d}/{}", job.what, job.total)),
            );
        } else {
            ui.label(&job.what);
        }
    }
    if !session.jobs.is_empty() && ui.button("cancel").clicked() {
        session.cancel.store(true, Ordering::Relaxed);
    }
    if let Some((err, m)) = session.messages.last() {
        let color = if *err {
            Color32::from_rgb(230, 60, 60)
        } else {
            ui.visuals().weak_text_color()
        };
        ui.colored_label(color, m);
    }
}
