//! A report's rows from evaluated episodes: what `eval` computes for each cell once its
//! episodes have run, in the library so that every consumer of a sweep (the command line, a
//! test, another tool) assembles a cell the same way.

use super::exploration::{EpisodeExploration, cell_exploration};
use super::failure::{behaviour_counts, class_counts, classes_of};
use super::grounding::WordKind;
use super::report::{Cell, CellAccuracy, size_and_objects};
use super::sweep::{EpisodeSummary, expert_stats, grounding, performance};
use super::words::by_word;
use crate::env::level::LevelConfig;
use crate::policy::Variant;

/// One cell's row of the report from its episodes and their exploration records: success and
/// reward, the grounding accuracies (object, colour, `M`, every word) of a model with maps,
/// the failure classes — `grounding` decided from `M`, or from the occlusion saliency that
/// stands in for it when `saliency` is set — and the exploration. Returns the row and the
/// episodes' summaries (for the worst-episode lists).
pub fn cell_from_episodes(
    checkpoint: &str,
    variant: Variant,
    level: &LevelConfig,
    explored: Vec<(EpisodeSummary, EpisodeExploration)>,
    saliency: bool,
) -> (Cell, Vec<EpisodeSummary>) {
    let exploration = cell_exploration(&explored);
    let eps: Vec<EpisodeSummary> = explored.into_iter().map(|(s, _)| s).collect();
    let attention = variant == Variant::Attention;
    let accuracy = attention.then(|| CellAccuracy {
        object: grounding(&eps, WordKind::Object),
        color: grounding(&eps, WordKind::Color),
        combined: grounding(&eps, WordKind::Combined),
        words: by_word(&eps),
        door: Some(grounding(&eps, WordKind::Door)).filter(|g| g.evaluated_steps > 0),
        location: Some(grounding(&eps, WordKind::Location)).filter(|g| g.evaluated_steps > 0),
        goal: Some(grounding(&eps, WordKind::Goal)).filter(|g| g.evaluated_steps > 0),
        lava: Some(grounding(&eps, WordKind::Lava)).filter(|g| g.evaluated_steps > 0),
        opening: Some(grounding(&eps, WordKind::Opening)).filter(|g| g.evaluated_steps > 0),
    });
    let mut classes = class_counts(
        eps.iter().filter_map(|e| e.failure.as_ref()),
        attention || saliency,
        level.babyai.is_some(),
    );
    // A MiniGrid environment's own classes, zeros included, where its rules can give them.
    if let Some(class) = level.babyai.and_then(crate::env::LevelId::minigrid) {
        for k in classes_of(&class) {
            classes.entry(k).or_insert(0);
        }
    }
    let (size, objects) = size_and_objects(level);
    let cell = Cell::new(
        checkpoint,
        variant.name(),
        size,
        objects,
        eps.len() as u64,
        &performance(&eps),
        accuracy,
    )
    .with_failure_classes(classes)
    .with_behaviours(behaviour_counts(
        eps.iter().filter_map(|e| e.failure.as_ref()),
    ))
    .with_exploration(exploration)
    .with_level(level.babyai.map(|id| id.id().to_owned()));
    let cell = Cell {
        expert: Some(expert_stats(&eps)),
        done_action_mode: level.babyai.is_some() && level.done_required,
        ..cell
    };
    (cell, eps)
}
