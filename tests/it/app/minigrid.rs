//! The debugger on MiniGrid's own environments: the lava the word "lava" names circled on the
//! world under its map, by whether the map passes τ there, and the maps on their own colour
//! scales by default.

use std::path::Path;

use crate::common::debugger::{build, show_until};
use crate::common::worlds::babyai;
use egui_kittest::kittest::Queryable as _;
use groundscope::app::session::Overlay;
use groundscope::app::{EpisodeRequest, Launch};
use groundscope::env::ObjectKind;
use groundscope::env::level::LevelConfig;
use groundscope::record::scene::{TILE_PX, referent_marks};
use groundscope::render::{RgbImage, px_in_image, visible_cells};

/// An untrained attention model of every word, saved as `DIR/fresh`.
fn fresh_checkpoint(dir: &Path, level: LevelConfig) -> String {
    crate::common::save_fresh_attention(dir, level)
}

/// On LavaCrossingS11N5, with the map of "lava" laid over the world, every lava cell in view
/// is circled in its grounding colour (white ≥ τ, orange near, red miss), as the 7×7 map
/// circles it; under `M` the same pixels are the map's ring, not the circle. The maps are on
/// their own scales (a MiniGrid mission), and the box turns the shared scale back on.
#[test]
fn the_lava_in_view_is_circled_under_the_map_of_lava() {
    let level = babyai("MiniGrid-LavaCrossingS11N5-v0");
    let seed = (0..50)
        .find(|&s| {
            let w = level.generate(s).unwrap();
            visible_cells(&w)
                .iter()
                .any(|&p| w.grid.get(p).is_some_and(|o| o.kind == ObjectKind::Lava))
        })
        .expect("lava in view at the start of a seed in 50");
    let dir = tempfile::tempdir().unwrap();
    let ckpt = fresh_checkpoint(dir.path(), level);
    let mut h = build(&Launch::new(EpisodeRequest::new(ckpt, level, seed)));
    show_until(&mut h, "step 0 of ");
    // A MiniGrid mission's maps start on their own scales.
    assert!(h.query_by_label_contains("each map 0 to").is_some());
    assert!(h.query_by_label_contains("shared scale").is_none());
    let shown = h.state().session().shown.clone().unwrap();
    let step = &shown.trace.steps[0];
    let att = step.attention.as_ref().unwrap();
    let lava = att.words.iter().position(|w| w.word == "lava").unwrap();
    let scene = shown.scene(0).unwrap();
    let marks = referent_marks(&step.world, scene.hits_of(Some(lava)));
    let in_view = visible_cells(&step.world)
        .into_iter()
        .filter(|&p| {
            step.world
                .grid
                .get(p)
                .is_some_and(|o| o.kind == ObjectKind::Lava)
        })
        .count();
    assert_eq!(marks.len(), in_view, "every lava cell in view, once");
    let ring = |img: &RgbImage, p| {
        let (x, y) = px_in_image(p, TILE_PX);
        img.get_pixel(x + 1, y + TILE_PX / 2).0
    };
    let selection = &mut h.state_mut().session_mut().selection;
    selection.overlay = Overlay::Word;
    selection.word = lava;
    h.run();
    let under_lava = h.state().world_image().unwrap();
    for &(p, color) in &marks {
        assert_eq!(ring(&under_lava, p), color, "lava at {p:?}");
    }
    h.state_mut().session_mut().selection.overlay = Overlay::Combined;
    h.run();
    let under_m = h.state().world_image().unwrap();
    for &(p, color) in &marks {
        assert_ne!(ring(&under_m, p), color, "no circle at {p:?} under M");
    }
    h.get_by_label("own scale").click();
    h.run();
    assert!(h.query_by_label_contains("shared scale").is_some());
}

/// Picking a MiniGrid id the loaded model cannot read runs `bundled:minigrid` instead, saying
/// so; the MiniGrid model is compared with the baseline trained beside it, not the paper's.
#[test]
fn a_minigrid_id_the_model_cannot_read_runs_the_minigrid_model() {
    let paper = groundscope::app::session::Agent::load("bundled:attention").unwrap();
    let mut h = build(&Launch::new(EpisodeRequest::new(
        "bundled:attention",
        paper.level(),
        1,
    )));
    show_until(&mut h, "step 0 of ");
    // What the level picker does on a pick (its MiniGrid rows are below the fold).
    let level = babyai("MiniGrid-DoorKey-5x5-v0");
    let session = h.state_mut().session_mut();
    session.request.level = level;
    assert!(
        session.fallback_where_unreadable(),
        "the paper's model reads DoorKey?"
    );
    show_until(&mut h, "cannot read this level");
    show_until(&mut h, "running the bundled MiniGrid model instead");
    show_until(&mut h, &level.generate(1).unwrap().mission);
    assert!(
        h.query_all_by_value("bundled:minigrid").next().is_some(),
        "the checkpoint field names the MiniGrid model"
    );

    let mut h = build(&Launch::new(EpisodeRequest::new(
        "bundled:minigrid",
        level,
        1,
    )));
    show_until(&mut h, "step 0 of ");
    assert!(
        h.query_all_by_value("bundled:minigrid-baseline")
            .next()
            .is_some(),
        "the compare field offers the MiniGrid baseline"
    );
}
