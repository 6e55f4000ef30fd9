//! The maps in view at every window size from 1280×800 up: on BossLevel (seeds 0 and 3, the
//! step a report names), PickupLoc, GoToSeqS5R2 and PutNextLocal, `M` and every word map
//! unfolded are whole, at least 90 points a side, inside the window and above the episode
//! plot; and the checkpoint field shows its whole name at 1280×800.

use crate::common::debugger::{build_sized, show_until};
use crate::common::wait_until;
use eframe::egui;
use egui_kittest::kittest::{NodeT as _, Queryable as _};
use groundscope::app::{EpisodeRequest, Launch};
use groundscope::env::level::{LevelConfig, LevelId};

fn options(id: &str, seed: u64, step: usize) -> Launch {
    let level = LevelConfig::babyai(LevelId::parse(id).unwrap(), false);
    Launch::new(EpisodeRequest {
        step,
        ..EpisodeRequest::new("bundled:babyai", level, seed)
    })
}

#[test]
fn every_map_is_whole_and_readable_at_every_window_size() {
    let cases = [
        // The report's worst BossLevel episode opens at its decisive step.
        ("BabyAI-BossLevel-v0", 0, 56),
        ("BabyAI-BossLevel-v0", 3, 0),
        ("BabyAI-PickupLoc-v0", 1, 2),
        ("BabyAI-GoToSeqS5R2-v0", 1, 3),
        ("BabyAI-PutNextLocal-v0", 1, 1),
    ];
    let mut failures = Vec::new();
    for size in [[1280.0, 800.0], [1400.0, 900.0], [1920.0, 1080.0]] {
        for (id, seed, step) in cases {
            let mut h = build_sized(&options(id, seed, step), size);
            show_until(&mut h, "step ");
            h.run();
            let plot_top = h
                .query_by_label_contains("over the episode")
                .map_or(size[1], |n| n.rect().min.y);
            let maps: Vec<_> = h
                .query_all_by_label_contains("map of ")
                .map(|n| (n.accesskit_node().label().unwrap_or_default(), n.rect()))
                .collect();
            let at = format!("{id} seed {seed} step {step} at {}×{}", size[0], size[1]);
            if !maps.iter().any(|(l, _)| l == "map of M") || maps.len() < 3 {
                failures.push(format!("{at}: maps drawn: {maps:?}"));
                continue;
            }
            for (label, r) in &maps {
                let whole = r.min.x >= 0.0 && r.min.y >= 0.0 && r.max.x <= size[0];
                if !whole || r.max.y > plot_top || r.width() < 90.0 || r.height() < 90.0 {
                    failures.push(format!("{at}: {label} at {r:?} (plot from y {plot_top})"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The checkpoint field names its checkpoint in full at 1280×800, as a screenshot shows it
/// (issue 83: "bundled:babyai-grounded" was cut by a field of 160 points): as wide as a name
/// that fits the bar's row, and a path longer than the row wraps onto more lines of a field
/// as wide as the row, inside the window.
#[test]
fn the_checkpoint_field_shows_the_whole_name() {
    let size = [1280.0, 800.0];
    let level = LevelConfig::babyai(LevelId::parse("BabyAI-GoToLocal-v0").unwrap(), false);
    // No such checkpoint: the field shows what was asked for, loaded or not.
    let long = format!(
        "{}/checkpoints/update-01200",
        ["runs/a-study-of-grounded-agents-on-babyai-levels"; 6].join("/")
    );
    let mut heights = Vec::new();
    for name in ["bundled:babyai-grounded", long.as_str()] {
        let mut h = build_sized(&Launch::new(EpisodeRequest::new(name, level, 0)), size);
        wait_until(&format!("{name} loaded or refused"), || {
            h.step();
            !h.state().session().busy()
        });
        h.run();
        // The field and its text run both hold the name; the field's rect holds the run's.
        let field = h
            .query_all_by_value(name)
            .map(|n| n.rect())
            .reduce(egui::Rect::union)
            .unwrap_or_else(|| panic!("no field holds {name}"));
        let font = egui::TextStyle::Body.resolve(&h.ctx.global_style());
        let text = h.ctx.fonts_mut(|f| {
            f.layout_no_wrap(name.to_owned(), font, egui::Color32::WHITE)
                .size()
                .x
        });
        assert!(
            field.min.x >= 0.0 && field.max.x <= size[0] && field.max.y <= size[1],
            "{name}: the field at {field:?} is not inside the window"
        );
        if text < 0.8 * size[0] {
            assert!(
                field.width() >= text,
                "{name}: a field {} wide for a name {text} wide",
                field.width()
            );
        } else {
            assert!(field.width() < text, "{name}: wrapped, not one line");
        }
        heights.push(field.height());
    }
    // The long path's field holds it on two lines at least.
    assert!(
        heights[1] >= 1.5 * heights[0],
        "the long name did not wrap: field heights {heights:?}"
    );
}
