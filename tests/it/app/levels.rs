//! The debugger on any BabyAI level: the level picker, the instruction tree with the clause the
//! verifier waits on and each clause's targets, and the doors with their states.

use std::path::Path;

use crate::common;
use crate::common::debugger::{build, show_until};
use crate::common::worlds::babyai;
use egui_kittest::kittest::{NodeT as _, Queryable as _};
use groundscope::app::session::Agent;
use groundscope::app::{EpisodeRequest, Launch};
use groundscope::env::level::{LevelConfig, LevelId};
use groundscope::env::tree::{InstructionTree, Stage, doors_text, targets_text};
use groundscope::env::{DoorState, Instr};
use groundscope::record::scene::TILE_PX;

/// An untrained attention model of all of BabyAI's words, saved as `DIR/fresh`: what
/// `train --level` starts from, enough to open any level's missions.
fn fresh_checkpoint(dir: &Path, level: LevelConfig) -> String {
    crate::common::save_fresh_attention(dir, level)
}

/// The debugger on `checkpoint` at `seed`, on `level` or (`None`) the checkpoint's own.
fn options(checkpoint: &str, level: Option<LevelConfig>, seed: u64) -> Launch {
    let level = level.unwrap_or_else(|| Agent::load(checkpoint).unwrap().level());
    Launch::new(EpisodeRequest::new(checkpoint, level, seed))
}

#[test]
fn a_babyai_level_names_itself_and_gets_a_world_of_its_size() {
    let agent = Agent::load("bundled:attention").unwrap();
    let level = LevelConfig {
        babyai: Some(LevelId::parse("BabyAI-GoTo-v0").unwrap()),
        ..agent.level()
    };
    let mut h = build(&options("bundled:attention", Some(level), 1));
    show_until(&mut h, "step 0 of ");
    // Not the paper level's "room 8 · objects 4", which would not describe it.
    h.get_by_value("BabyAI-GoTo-v0");
    assert!(h.query_by_label("room").is_none());
    let img = h.state().world_image().unwrap();
    assert_eq!(img.dimensions(), (22 * TILE_PX, 22 * TILE_PX));
}

#[test]
fn the_level_picker_offers_every_level_and_runs_the_one_picked() {
    let mut h = build(&options("bundled:attention", None, 5));
    show_until(&mut h, "step 0 of ");
    assert!(h.query_by_label("room").is_some(), "the paper level's room");
    h.get_by_value("the paper's").click();
    h.run();
    let offered = h.query_all_by_label_contains("BabyAI-").count();
    assert_eq!(
        offered, 96,
        "every registered BabyAI level of minigrid 3.2.0"
    );
    let id = "BabyAI-FindObjS5-v0";
    h.get_by_label(id).click();
    // As minigrid registers it (no done action), as `view --level` runs it.
    let level = LevelConfig::babyai(LevelId::parse(id).unwrap(), false);
    let world = level.generate(5).unwrap();
    let want = (
        world.grid.width() as u32 * TILE_PX,
        world.grid.height() as u32 * TILE_PX,
    );
    common::wait_until("the picked level's episode", || {
        h.step();
        h.state().world_image().map(|i| i.dimensions()) == Some(want)
    });
    show_until(&mut h, &world.mission);
    h.get_by_value(id);
    assert!(h.query_by_label("room").is_none());
}

#[test]
fn the_instruction_tree_shows_the_clause_waited_on_and_each_clauses_targets() {
    let dir = tempfile::tempdir().unwrap();
    let level = babyai("BabyAI-GoToSeqS5R2-v0");
    let ckpt = fresh_checkpoint(dir.path(), level);
    let (seed, world) = (0..100)
        .map(|s| (s, level.generate(s).unwrap()))
        .find(|(_, w)| matches!(&w.instr, Instr::Seq(_)))
        .expect("a sequence in 100 seeds");
    let mut h = build(&options(&ckpt, Some(level), seed));
    show_until(&mut h, "step 0 of ");
    h.get_by_label(&world.mission);
    let tree = InstructionTree::of(&world);
    assert!(tree.nodes.len() >= 3, "a sequence and its two parts");
    for n in &tree.nodes {
        match n.clause {
            Some(c) => {
                h.get_by_label(&format!("{} · {}", c + 1, n.text));
                let targets = format!("targets: {}", targets_text(&n.targets));
                assert!(h.query_all_by_label(&targets).next().is_some(), "{targets}");
            }
            None => assert!(h.query_all_by_label(&n.text).next().is_some(), "{}", n.text),
        }
    }
    let waiting = tree
        .nodes
        .iter()
        .filter(|n| n.stage == Stage::Waiting)
        .count();
    assert!(
        waiting >= 2,
        "the sequence and at least one clause are waited on"
    );
    assert_eq!(h.query_all_by_label("waiting").count(), waiting);
    let later = tree
        .nodes
        .iter()
        .filter(|n| n.stage == Stage::Later)
        .count();
    assert_eq!(h.query_all_by_label("later").count(), later);
}

#[test]
fn a_door_level_lists_its_doors_and_their_states() {
    let dir = tempfile::tempdir().unwrap();
    let level = babyai("BabyAI-UnlockLocal-v0");
    let ckpt = fresh_checkpoint(dir.path(), level);
    let world = level.generate(1).unwrap();
    let tree = InstructionTree::of(&world);
    assert!(tree.doors.iter().any(|d| d.state == DoorState::Locked));
    let mut h = build(&options(&ckpt, Some(level), 1));
    show_until(&mut h, "step 0 of ");
    // Each door with its colour, cell and state, as the recordings give them.
    let text = format!("doors: {}", doors_text(&tree.doors));
    assert!(text.contains("locked"), "{text}");
    h.get_by_label(&text);
}

#[test]
fn the_mission_editor_names_the_words_this_model_was_not_trained_on() {
    // The bundled model reads the paper's 25 words; BabyAI's split makes "door," one word.
    let mut opts = options("bundled:attention", None, 3);
    opts.request.mission = Some("go to the red door, then pick up a key".into());
    let mut h = build(&opts);
    show_until(&mut h, "not a word this model knows: door, then");
    assert!(
        h.get_by_label("apply at this step")
            .accesskit_node()
            .is_disabled(),
        "a mission this model cannot read is not applied"
    );
    // A model of all of BabyAI's words takes it.
    let dir = tempfile::tempdir().unwrap();
    let ckpt = fresh_checkpoint(dir.path(), babyai("BabyAI-GoToSeq-v0"));
    let mut opts = options(&ckpt, None, 3);
    opts.request.mission = Some("go to the red ball, then pick up a key".into());
    let mut h = build(&opts);
    show_until(&mut h, "step 0 of ");
    assert!(
        h.query_by_label_contains("not a word this model knows")
            .is_none()
    );
    assert!(
        !h.get_by_label("apply at this step")
            .accesskit_node()
            .is_disabled()
    );
}

/// Picking a level the loaded model cannot read runs `bundled:babyai` instead, saying so, with
/// the expert's action beside it.
#[test]
fn a_level_the_pair_cannot_read_runs_the_babyai_model() {
    let mut h = build(&options("bundled:attention", None, 3));
    show_until(&mut h, "step 0 of ");
    // Beside the bundled model on the paper's level: the expert's action and plan.
    show_until(&mut h, "expert (minigrid's bot): ");
    h.get_by_value("the paper's").click();
    h.run();
    // A level high in the picker's list, so that its row is on screen to be clicked.
    h.get_by_label("BabyAI-GoToDoor-v0").click();
    show_until(&mut h, "cannot read this level");
    show_until(&mut h, "running the bundled BabyAI model instead");
    let world = babyai("BabyAI-GoToDoor-v0").generate(3).unwrap();
    show_until(&mut h, &world.mission);
    show_until(&mut h, "expert (minigrid's bot): ");
    assert!(
        h.query_all_by_value("bundled:babyai").next().is_some(),
        "the checkpoint field names the BabyAI model"
    );
}

/// The bot as the agent: its plan stands where the maps would be.
#[test]
fn the_bot_shows_its_plan_in_place_of_the_maps() {
    let mut h = build(&options("bot", Some(babyai("BabyAI-GoToDoor-v0")), 3));
    show_until(&mut h, "step 0 of ");
    let world = babyai("BabyAI-GoToDoor-v0").generate(3).unwrap();
    show_until(&mut h, &world.mission);
    show_until(&mut h, "plan: GoNextTo ");
    show_until(&mut h, "no attention maps and no network to probe");
}

/// A long mission's maps stay on screen: `M` first, the words' maps grouped by clause, the
/// function words folded into one line (and out of the weight bars) until the box is unticked.
#[test]
fn a_long_missions_maps_fold_their_function_words_and_keep_m_in_view() {
    let level = babyai("BabyAI-SynthSeq-v0");
    let world = level.generate(3).unwrap();
    assert!(world.mission.split(' ').count() > 9, "{}", world.mission);
    let mut h = build(&options("bundled:babyai", Some(level), 3));
    show_until(&mut h, "step 0 of ");
    show_until(&mut h, "folded (w): ");
    show_until(&mut h, "word weights w (function words folded)");
    assert!(h.query_by_label_contains("combined M").is_some());
    // The folded words have no map title of their own; a word with a role has one.
    assert!(h.query_all_by_label("the").next().is_none());
    assert!(h.query_all_by_label("door").next().is_some());
    // The episode plot's legend lists the words shown, and says the rest are folded.
    let legend = |h: &egui_kittest::Harness<'_, groundscope::app::Debugger>| {
        h.query_all_by_label_contains("w of ").count()
    };
    let words = world
        .mission
        .split([' ', ','])
        .filter(|w| !w.is_empty())
        .count();
    let shown = legend(&h);
    assert!(
        shown > 0 && shown < words,
        "{shown} of {words} in the legend"
    );
    assert!(h.query_by_label("w of the").is_none());
    h.get_by_label("(function words folded)");
    h.get_by_label("fold function words").click();
    h.run();
    show_until(&mut h, "word weights w");
    assert!(h.query_by_label_contains("folded (w)").is_none());
    assert!(h.query_all_by_label("the").next().is_some());
    assert_eq!(legend(&h), words);
    // Unfolded, M and the box to fold again are still in the window.
    for label in ["combined M", "fold function words"] {
        let r = h.get_by_label(label).rect();
        assert!(r.max.y <= 900.0 && r.min.y >= 0.0, "{label} at {r:?}");
    }
}

/// An agent without maps (rl-starter-files' ACModel as ONNX): the overlay offers no `M` and no
/// word, the occlusion map standing in for the maps has the word maps' outlines and a colour
/// bar of its own, and no ρ(M, Δ) names an `M` that does not exist.
#[test]
fn an_agent_without_maps_is_offered_nothing_it_lacks() {
    let level = babyai("BabyAI-GoToRedBallGrey-v0");
    let mut h = build(&options(
        "tests/fixtures/onnx/acmodel_gotoredballgrey.onnx",
        Some(level),
        2,
    ));
    show_until(&mut h, "step 0 of ");
    show_until(&mut h, "no attention maps: the occlusion saliency");
    show_until(&mut h, "Δ's own scale");
    for name in ["M", "selected word"] {
        assert!(
            h.get_by_label(name).accesskit_node().is_disabled(),
            "the {name} overlay is offered"
        );
    }
    assert!(h.query_by_label_contains("ρ(M, Δ)").is_none());
}

/// A long episode opens before it has been run to its end: the steps come in as they are
/// taken, the step asked for shows once it is there, and the episode that ends is the one
/// `replay` runs (BossLevel seed 3 runs to its 1,728-step limit).
#[test]
fn a_long_episode_streams_in_and_opens_at_the_step_asked_for() {
    let level = babyai("BabyAI-BossLevel-v0");
    let mut opts = options("bundled:babyai", Some(level), 3);
    opts.request.step = 1000;
    let mut h = build(&opts);
    show_until(&mut h, "step 1000 of 0–1727 · failure");
    assert_eq!(h.state().episode_progress(), Some((1728, true)));
    h.state_mut().go_to_step(5000);
    show_until(&mut h, "step 1727 of 0–1727 · failure");
}

/// Stepping through a long episode keeps the textures of a window of its pictures, not one
/// per step shown (issue #83): with each of 100 steps shown in turn, its world and its view
/// drawn, egui never holds more textures than at the first step and the 64 pictures the
/// world panel keeps (one per step shown would be 200).
#[test]
fn stepping_through_a_long_episode_keeps_a_window_of_textures() {
    let level = babyai("BabyAI-BossLevel-v0");
    let mut h = build(&options("bundled:babyai", Some(level), 3));
    show_until(&mut h, "step 0 of 0–1727");
    let first = h.ctx.tex_manager().read().num_allocated();
    let mut most = first;
    for k in 1..100 {
        h.state_mut().go_to_step(k);
        h.step();
        most = most.max(h.ctx.tex_manager().read().num_allocated());
    }
    assert!(
        most > 40,
        "each step shown draws its pictures: {most} textures at most"
    );
    assert!(
        most <= first + 64,
        "{most} textures after 100 steps shown, {first} at the first"
    );
}

/// A failed episode names its class and behaviour and offers its decisive step — the step
/// `eval` gives the same episode — and the button goes there.
#[test]
fn a_failed_episode_offers_the_decisive_step_eval_gives_it() {
    use groundscope::app::session::run_request;
    use groundscope::episode::ActionMode;
    let dir = tempfile::tempdir().unwrap();
    let level = babyai("BabyAI-GoToLocal-v0");
    let ckpt = fresh_checkpoint(dir.path(), level);
    let agent = Agent::load(&ckpt).unwrap();
    let (seed, shown) = (0..20)
        .find_map(|seed| {
            let request = EpisodeRequest::new(ckpt.clone(), level, seed);
            let shown = run_request(&agent, &request, 0.5).unwrap();
            (!shown.trace.success()).then_some((seed, shown))
        })
        .expect("a fresh model fails some GoToLocal seed");
    let d = shown.failure.unwrap();
    let decisive = shown.decisive.unwrap();
    // eval's sweep finds the same step.
    let eps = groundscope::metrics::sweep::evaluate_episodes(
        agent.acting(),
        &level,
        &[(0, seed)],
        0.5,
        ActionMode::Greedy,
        &mut |_| {},
    )
    .unwrap();
    let e = &eps[0];
    let lost = e.failure.unwrap().lost_at;
    let want =
        groundscope::metrics::failure::decisive_step(lost, e.expert.first_divergence, e.length);
    assert_eq!(decisive, want as usize);
    let mut h = build(&options(&ckpt, Some(level), seed));
    show_until(&mut h, "step 0 of ");
    let behaviour = d
        .behaviour
        .map_or_else(String::new, |b| format!(" · {}", b.name()));
    h.get_by_label(&format!("failed: {}{behaviour}", d.class.name()));
    h.get_by_label(&format!("decisive step {decisive}")).click();
    show_until(&mut h, &format!("step {decisive} of "));
}

/// A 9-word mission's ten maps end inside the window at 1280×900 and 1400×900 (the last map
/// was cut at the right edge), and no map caption breaks inside a figure.
#[test]
fn nine_word_missions_fit_their_maps_in_the_window() {
    for (id, seed) in [("BabyAI-PutNextLocal-v0", 3), ("BabyAI-OpenTwoDoors-v0", 1)] {
        for width in [1280.0f32, 1400.0] {
            let mut opts = options("bundled:babyai", Some(babyai(id)), seed);
            opts.request.step = 1;
            let mut h = egui_kittest::Harness::builder()
                .with_size([width, 900.0])
                .with_accessibility_check(false)
                .build_ui_state(
                    |ui, d: &mut groundscope::app::Debugger| d.frame(ui),
                    groundscope::app::Debugger::new(&opts, None),
                );
            show_until(&mut h, "step 1 of ");
            // Panels take their size from the frame before: let the layout settle.
            for _ in 0..3 {
                h.step();
            }
            // A label's text is its node's value.
            let captions: Vec<_> = h.query_all_by_label_contains("w 0").collect();
            let maps = captions
                .iter()
                .filter(|n| {
                    n.accesskit_node()
                        .value()
                        .is_some_and(|l| l.starts_with("w "))
                })
                .count();
            assert_eq!(maps, 9, "{id} at {width}: one caption per word");
            for n in &captions {
                let label = n.accesskit_node().value().unwrap_or_default();
                if !label.starts_with("w ") {
                    continue;
                }
                assert!(
                    n.rect().max.x <= width,
                    "{id} at {width}: {label:?} ends at {}",
                    n.rect().max.x
                );
                // "w 0.072\nH 2.46" or "w 0.072 · H 2.46": each figure whole on its line.
                for line in label.lines() {
                    assert!(
                        line.split(" · ").all(|f| f.split(' ').count() == 2),
                        "{label:?}"
                    );
                }
            }
            let combined = h.get_by_label("combined M").rect();
            assert!(combined.height() < 25.0, "'combined M' on one line");
            // The episode plot in view, whole, above the timeline; the maps above it, whole.
            let plot = h.get_by_label("episode plot").rect();
            let timeline = h.get_by_label("next grounding miss").rect();
            assert!(
                plot.height() >= 70.0 && plot.max.y <= timeline.min.y,
                "{id} at {width}: plot {plot:?}, timeline at {}",
                timeline.min.y
            );
            // Under its caption each map is at least 50 points on a side.
            let lowest = captions.iter().map(|n| n.rect().max.y).fold(0.0, f32::max);
            assert!(
                lowest + 50.0 <= plot.min.y,
                "{id} at {width}: captions end at {lowest}, the plot starts at {}",
                plot.min.y
            );
        }
    }
}
