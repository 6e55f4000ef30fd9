//! The debugger: what its panels show and how they respond, through egui's test harness
//! (`egui_kittest`, reading the UI's AccessKit tree); a real frame rendered under Xvfb; and its
//! errors.

use crate::common;
use crate::common::debugger::{build, show_until};

use std::process::{Command, Output};

use eframe::egui;
use egui::accesskit::Toggled;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT as _, Queryable as _};
use groundscope::app::session::{Agent, Shown, run_request};
use groundscope::app::{Debugger, EpisodeRequest, Launch};
use groundscope::episode::ActionMode;
use groundscope::metrics::faithfulness::annotate_step;
use groundscope::metrics::faithfulness::peaks::peak_line;
use groundscope::record::scene::{NEGLIGIBLE_WEIGHT, TILE_PX, no_accuracy_reason, shown_kinds};
use groundscope::render::{palette, px_in_image, render_world};

fn gs(args: &[&str], display: Option<&str>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_groundscope"));
    cmd.args(args)
        .env("RAYON_NUM_THREADS", "1")
        .env_remove("WAYLAND_DISPLAY");
    match display {
        Some(d) => cmd.env("DISPLAY", d),
        None => cmd.env_remove("DISPLAY"),
    };
    cmd.output().expect("the binary runs")
}

/// The screenshot under `xvfb-run` (CI installs it: `apt-get install xvfb xauth`).
fn xvfb_screenshot(args: &[&str]) -> Output {
    let mut cmd = Command::new("xvfb-run");
    cmd.args(["-a", "-s", "-screen 0 1600x1000x24"])
        .arg(env!("CARGO_BIN_EXE_groundscope"))
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .env("LIBGL_ALWAYS_SOFTWARE", "1");
    cmd.output()
        .expect("xvfb-run is needed for this test: apt-get install xvfb xauth")
}

#[test]
fn screenshot_renders_the_real_panels() {
    // The real window (eframe, OpenGL) and the screenshot path; what the panels show is
    // checked through egui's own harness below.
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let o = xvfb_screenshot(&[
        "view",
        "--screenshot",
        shot.to_str().unwrap(),
        "--seed",
        "3",
        "--step",
        "2",
        "--window",
        "1200x800",
    ]);
    assert!(
        o.status.success(),
        "stdout: {}\nstderr: {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim_end(),
        format!("wrote {}", shot.display())
    );
    let img = image::open(&shot).unwrap().to_rgb8();
    // The window's size (logical = physical pixels under Xvfb).
    assert_eq!(img.dimensions(), (1200, 800));
    // A drawn frame, not a blank one: the world picture in the left panel and the row of word
    // maps in the central panel each hold more than one colour.
    for (name, x0, x1, y0, y1) in [
        ("world picture", 10, 330, 120, 440),
        ("row of word maps", 350, 1190, 370, 500),
    ] {
        let first = *img.get_pixel(x0, y0);
        assert!(
            (x0..x1).any(|x| (y0..y1).any(|y| *img.get_pixel(x, y) != first)),
            "the {name} is a flat colour"
        );
    }
}

#[test]
fn no_display_is_a_clear_error_that_suggests_a_recording() {
    let o = gs(&["view", "--seed", "1"], None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("no display") && err.contains("replay"),
        "{err}"
    );
    // Without a subcommand the debugger is what starts.
    let o = gs(&[], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no display"));
}

#[test]
fn bad_view_arguments_are_one_line_errors() {
    for (args, what) in [
        (vec!["view", "--window", "big"], "--window"),
        // The window's old spelling is still accepted.
        (vec!["view", "--size", "big"], "--window"),
        (vec!["view", "--checkpoint", "nope/missing"], "nope/missing"),
        (vec!["view", "--mission", "go to the pink key"], "pink"),
        (vec!["view", "--screenshot", "out.jpg"], ".png"),
        (vec!["view", "--room-size", "3"], "3"),
    ] {
        let o = gs(&args, Some(":99999"));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(what), "{args:?}: expected {what:?} in {err}");
    }
}

/// The debugger as `groundscope view --seed 3 --step STEP` opens it, in egui's test harness.
fn debugger(step: usize, faithfulness: bool) -> Harness<'static, Debugger> {
    debugger_of("bundled:attention", None, step, faithfulness)
}

/// [`debugger`] on another seed.
fn debugger_seed(seed: u64, step: usize, faithfulness: bool) -> Harness<'static, Debugger> {
    build(&Launch {
        faithfulness,
        ..Launch::new(request_of("bundled:attention", seed, step))
    })
}

/// [`debugger`] for `checkpoint` (and `compare`, side by side).
fn debugger_of(
    checkpoint: &str,
    compare: Option<&str>,
    step: usize,
    faithfulness: bool,
) -> Harness<'static, Debugger> {
    build(&Launch {
        compare: compare.map(str::to_owned),
        faithfulness,
        ..Launch::new(request_of(checkpoint, 3, step))
    })
}

/// `checkpoint` on its own level at `seed`, greedy, opening at `step`.
fn request_of(checkpoint: &str, seed: u64, step: usize) -> EpisodeRequest {
    let level = Agent::load(checkpoint).unwrap().level();
    EpisodeRequest {
        step,
        ..EpisodeRequest::new(checkpoint, level, seed)
    }
}

/// The episode the debugger runs, run here without it.
fn episode() -> (Agent, Shown) {
    episode_of(3)
}

/// The episode of `seed` as the debugger runs it.
fn episode_of(seed: u64) -> (Agent, Shown) {
    let agent = Agent::load("bundled:attention").unwrap();
    let request = EpisodeRequest {
        mode: ActionMode::Greedy,
        ..EpisodeRequest::new("bundled:attention", agent.level(), seed)
    };
    let shown = run_request(&agent, &request, 0.5).unwrap();
    (agent, shown)
}

/// The labels of the policy panel for step `k` of `shown`.
fn policy_labels(shown: &Shown, k: usize) -> [String; 2] {
    let step = &shown.trace.steps[k];
    [
        format!(
            "step {k} of 0–{} · {} · total reward {:.3}",
            shown.len() - 1,
            if shown.trace.success() {
                "success"
            } else {
                "failure"
            },
            shown.trace.total_reward()
        ),
        format!(
            "action {} · value {:.3} · reward {:.3}",
            step.action.name(),
            step.value,
            step.reward
        ),
    ]
}

#[test]
fn the_debugger_shows_the_step_it_opens_on_and_steps_with_the_arrow_keys() {
    let (_, shown) = episode();
    assert!(shown.len() > 4, "seed 3 has {} steps", shown.len());
    let mut h = debugger(2, false);
    show_until(&mut h, "step 2 of ");
    for label in policy_labels(&shown, 2) {
        h.get_by_label(&label);
    }
    let step = &shown.trace.steps[2];
    h.get_by_label(&step.world.mission);
    // A map per word of the mission, and the combined map.
    let words = &step.attention.as_ref().unwrap().words;
    assert!(!words.is_empty());
    for w in words {
        assert!(
            h.query_all_by_label(&w.word).next().is_some(),
            "no map of {:?}",
            w.word
        );
        h.get_by_label(&format!("w {:.3} · H {:.2}", w.weight, w.entropy));
    }
    for label in [
        "combined M",
        "word weights w",
        "agent view (agent-up; hatched: not seen)",
    ] {
        h.get_by_label(label);
    }
    // The faithfulness view is one click away, not open.
    let faithful = h.get_by_label(FAITHFULNESS_BOX);
    assert_eq!(faithful.accesskit_node().toggled(), Some(Toggled::False));
    assert!(h.query_by_label("occlusion Δ").is_none());
    // → moves to the next step, ← back.
    h.key_press(egui::Key::ArrowRight);
    show_until(&mut h, "step 3 of ");
    for label in policy_labels(&shown, 3) {
        h.get_by_label(&label);
    }
    h.key_press(egui::Key::ArrowLeft);
    show_until(&mut h, "step 2 of ");
}

const FAITHFULNESS_BOX: &str = "faithfulness: does this step's behaviour depend on M?";

#[test]
fn the_faithfulness_box_adds_this_steps_occlusion_map() {
    let (agent, shown) = episode();
    let f = annotate_step(agent.acting(), &shown.trace, 1).unwrap();
    let rho = match f.rank_correlation {
        Some(r) => format!("Spearman ρ(M, Δ) = {r:.3}"),
        None => "ρ(M, Δ): undefined (M or Δ constant)".to_owned(),
    };
    let mut h = debugger(1, false);
    show_until(&mut h, "step 1 of ");
    assert!(h.query_by_label("occlusion Δ").is_none());
    assert!(h.query_by_label(&rho).is_none());
    h.get_by_label(FAITHFULNESS_BOX).click();
    show_until(&mut h, "occlusion Δ");
    assert_eq!(
        h.get_by_label(FAITHFULNESS_BOX).accesskit_node().toggled(),
        Some(Toggled::True)
    );
    h.get_by_label(&rho);
    for (name, e) in &f.interventions {
        let flips = if e.flip { "flips" } else { "kept" };
        h.get_by_label(&format!("{name}: TV {:.3} · best action {flips}", e.tv));
    }
    // Whether the peaks agree stands next to ρ.
    let m = &shown.trace.steps[1].attention.as_ref().unwrap().combined;
    h.get_by_label(&peak_line(m, &f.occlusion));
    // Δ stands beside M, in the same row, and the probes are in sight at 1400×900.
    let (m_title, delta_title) = (
        h.get_by_label("combined M").rect(),
        h.get_by_label("occlusion Δ").rect(),
    );
    assert!(
        (m_title.min.y - delta_title.min.y).abs() < 2.0,
        "{m_title:?} {delta_title:?}"
    );
    assert!(
        delta_title.min.x > m_title.max.x,
        "{m_title:?} {delta_title:?}"
    );
    for probe in ["M uniform", "M steered to a distractor"] {
        let r = h.get_by_label(probe).rect();
        assert!(
            r.max.y <= 900.0 - 30.0,
            "{probe} at {r:?} is scrolled out of a 900-point window"
        );
    }
    // `view --faithfulness` opens with it shown.
    let mut h = debugger(1, true);
    show_until(&mut h, "step 1 of ");
    h.get_by_label("occlusion Δ");
    h.get_by_label(&rho);
}

fn onnx_fixture(name: &str) -> String {
    common::onnx_fixture(name).to_string_lossy().into_owned()
}

#[test]
fn an_onnx_graph_without_maps_opens_with_its_occlusion_saliency_in_their_place() {
    let acmodel = onnx_fixture("acmodel.onnx");
    let agent = Agent::load(&acmodel).unwrap();
    let request = EpisodeRequest {
        mode: ActionMode::Greedy,
        ..EpisodeRequest::new(acmodel.clone(), agent.level(), 3)
    };
    let shown = run_request(&agent, &request, 0.5).unwrap();
    assert!(shown.trace.steps.iter().all(|s| s.attention.is_none()));
    let k = 1.min(shown.len() - 1);
    let f = annotate_step(agent.acting(), &shown.trace, k).unwrap();
    let mut h = debugger_of(&acmodel, Some("bundled:attention"), k, false);
    show_until(&mut h, &format!("step {k} of "));
    for label in policy_labels(&shown, k) {
        assert!(h.query_all_by_label(&label).next().is_some(), "{label}");
    }
    // No checkbox to tick: the occlusion map is there, with this step's scale, and no probe
    // that would need M.
    assert!(h.query_by_label(FAITHFULNESS_BOX).is_none());
    h.get_by_label_contains("no attention maps: the occlusion saliency below");
    show_until(&mut h, "occlusion Δ");
    let hi = f.occlusion.iter().flatten().fold(1e-6f32, |a, b| a.max(*b));
    h.get_by_label(&format!("scale 0–{hi:.3}"));
    assert!(h.query_by_label("M uniform").is_none());
    // The native model beside it.
    h.get_by_label_contains("compare: bundled:attention");
}

#[test]
fn screenshot_of_an_onnx_graph_beside_a_native_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("onnx.png");
    let o = xvfb_screenshot(&[
        "view",
        "--checkpoint",
        &onnx_fixture("bundled_attention.onnx"),
        "--compare",
        "bundled:attention",
        "--screenshot",
        shot.to_str().unwrap(),
        "--seed",
        "3",
        "--step",
        "2",
        "--window",
        "1200x800",
    ]);
    assert!(
        o.status.success(),
        "stdout: {}\nstderr: {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let img = image::open(&shot).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (1200, 800));
    // The exported graph's word maps are drawn in the central panel.
    let (x0, x1, y0, y1) = (350, 890, 370, 500);
    let first = *img.get_pixel(x0, y0);
    assert!(
        (x0..x1).any(|x| (y0..y1).any(|y| *img.get_pixel(x, y) != first)),
        "the row of word maps is a flat colour"
    );
}

/// A graph without maps is shown by its own name, and its faithfulness view says why there
/// is nothing under "one step with M changed" (it used to show the heading alone).
#[test]
fn a_graph_without_maps_is_named_and_says_it_has_no_interventions() {
    let graph = onnx_fixture("renamed.onnx");
    let mut h = debugger_of(&graph, None, 0, true);
    show_until(&mut h, "step 0 of ");
    h.get_by_label("tiny policy (test) (renamed.onnx)");
    show_until(
        &mut h,
        "no interventions on M: this model outputs no attention maps",
    );
    assert!(h.query_by_label("one step with M changed:").is_none());
}

#[test]
fn objects_keep_their_palette_colours_under_the_overlay() {
    // The example is seed 7, where M once turned the green box yellow; the first step
    // of it (or of seed 3) with a ball in view also checks a palette colour exactly (a ball's
    // centre is filled; a box is a thin frame, blended at 16 pixels a cell).
    let ball_in_view = |shown: &Shown| {
        shown.trace.steps.iter().position(|s| {
            groundscope::render::visible_cells(&s.world)
                .iter()
                .any(|&p| s.world.grid.get(p).is_some_and(|o| o.kind.name() == "ball"))
        })
    };
    let (seed, shown, k) = [7, 3, 32]
        .into_iter()
        .find_map(|seed| {
            let (_, shown) = episode_of(seed);
            ball_in_view(&shown).map(|k| (seed, shown, k))
        })
        .expect("a ball comes into view");
    let mut h = debugger_seed(seed, k, false);
    show_until(&mut h, &format!("step {k} of "));
    let step = &shown.trace.steps[k];
    let img = h
        .state()
        .world_image()
        .expect("the world panel has a picture");
    let plain = render_world(&step.world, TILE_PX, true);
    assert_eq!(img.dimensions(), plain.dimensions());
    let ts = TILE_PX;
    // The attention ring and the target's corners are the outer eighth of a cell.
    let ring = ts / 8;
    let (mut objects, mut balls, mut tinted) = (0, 0, 0);
    for (x, y) in groundscope::render::visible_cells(&step.world) {
        let (px, py) = px_in_image((x, y), ts);
        let centre = (px + ts / 2, py + ts / 2);
        match step.world.grid.get((x, y)) {
            Some(o) if o.kind.name() != "wall" => {
                objects += 1;
                for dy in ring..ts - ring {
                    for dx in ring..ts - ring {
                        let (got, want) = (
                            img.get_pixel(px + dx, py + dy),
                            plain.get_pixel(px + dx, py + dy),
                        );
                        assert_eq!(got, want, "{} at ({x}, {y}) changed colour", o.describe());
                    }
                }
                if o.kind.name() == "ball" {
                    balls += 1;
                    let got = img.get_pixel(centre.0, centre.1).0;
                    let color = palette::object(o.color);
                    assert!(
                        got == color || got == palette::highlight(color),
                        "{} at ({x}, {y}) is {got:?} under M, not its palette {color:?}",
                        o.describe()
                    );
                }
            }
            None if (x, y) != step.world.agent_pos
                && img.get_pixel(centre.0, centre.1) != plain.get_pixel(centre.0, centre.1) =>
            {
                tinted += 1;
            }
            _ => {}
        }
    }
    assert!(objects > 0 && balls > 0, "seed {seed} step {k}");
    assert!(tinted > 0, "the overlay tints the floor it covers");
    // With the overlay off the picture is the plain world but for the targets' corners.
    h.get_by_label("none").click();
    h.run();
    let off = h.state().world_image().unwrap();
    let (tx, ty) = px_in_image(step.world.target_positions()[0], ts);
    assert_eq!(off.get_pixel(tx, ty).0, palette::TARGET);
    assert_eq!(
        off.get_pixel(tx + ts / 2, ty + ts / 2),
        plain.get_pixel(tx + ts / 2, ty + ts / 2)
    );
}

#[test]
fn the_panels_say_what_their_numbers_mean() {
    let (_, shown) = episode();
    let mut h = debugger(0, false);
    show_until(&mut h, "step 0 of ");
    for label in ["action probabilities", "word weights w", "forward", "done"] {
        assert!(h.query_all_by_label(label).next().is_some(), "{label}");
    }
    h.get_by_label_contains("shared scale");
    h.get_by_label_contains("magenta corners: target");
    // The episode at a glance fills the rest of the column: a line per word's w.
    h.get_by_label("over the episode:");
    for w in &shown.trace.steps[0].attention.as_ref().unwrap().words {
        h.get_by_label(&format!("w of {}", w.word));
    }
    // Every step either shows each kind of accuracy or says why not; a word whose weight is
    // about 0 says it is not in M.
    let mut reasons = 0;
    for (k, step) in shown.trace.steps.iter().enumerate() {
        let scene = shown.scene(k).unwrap();
        if k > 0 {
            h.key_press(egui::Key::ArrowRight);
            show_until(&mut h, &format!("step {k} of "));
        }
        let shown_kinds = shown_kinds(&step.world);
        for kind in groundscope::metrics::grounding::WordKind::ALL {
            if scene.grounding.iter().all(|g| g.kind != kind) {
                let reason = no_accuracy_reason(kind, &step.world);
                if shown_kinds.contains(&kind) {
                    h.get_by_label(&reason);
                    reasons += 1;
                } else {
                    // The paper's missions have no door or location word: nothing to explain.
                    assert!(h.query_by_label(&reason).is_none(), "{reason}");
                }
            }
        }
        let dim = step
            .attention
            .as_ref()
            .unwrap()
            .words
            .iter()
            .filter(|w| w.weight < NEGLIGIBLE_WEIGHT)
            .count();
        assert_eq!(
            h.query_all_by_label("w < 0.005: not in M").count(),
            dim,
            "step {k}"
        );
    }
    assert!(
        reasons > 0,
        "seed 3 has a step with nothing related in view"
    );
}

#[test]
fn a_step_past_the_end_is_said_not_clamped_silently() {
    let (_, shown) = episode();
    let last = shown.len() - 1;
    let mut h = debugger(last + 40, false);
    show_until(&mut h, &format!("step {last} of 0–{last}"));
    h.get_by_label(&format!(
        "--step {} is past this episode's last step {last}; showing step {last}",
        last + 40
    ));
}

/// A `--window` larger than the screen says so, with a size that fits; one that fits says
/// nothing.
#[test]
fn a_window_larger_than_the_screen_says_so() {
    for (monitor, warned) in [
        (egui::vec2(1280.0, 800.0), true),
        (egui::vec2(1920.0, 1080.0), false),
    ] {
        let mut h = debugger(0, false);
        h.state_mut().asked_window([1400.0, 900.0]);
        h.input_mut()
            .viewports
            .entry(egui::ViewportId::ROOT)
            .or_default()
            .monitor_size = Some(monitor);
        show_until(&mut h, "step 0 of ");
        h.run();
        let said = h
            .query_by_label_contains("--window 1400x900 is larger than the screen (1280x800)")
            .is_some();
        assert_eq!(said, warned, "monitor {monitor:?}");
    }
    assert!(
        groundscope::app::window_warning([1400.0, 900.0], egui::vec2(1280.0, 800.0))
            .unwrap()
            .contains("pass --window 1280x800 or smaller")
    );
}

/// `view --seed 9007199254740993`: the top bar's seed field shows the seed as given (egui's
/// DragValue held it as an f64 and showed …992), and the episode shown is that seed's.
#[test]
fn the_seed_field_is_exact_above_two_to_the_53() {
    let seed = 9_007_199_254_740_993;
    let mut h = debugger_seed(seed, 0, false);
    show_until(&mut h, "step 0 of ");
    assert!(
        h.query_all_by_value("9007199254740993").next().is_some(),
        "no field shows the seed as given"
    );
    assert!(h.query_all_by_value("9007199254740992").next().is_none());
    assert_eq!(h.state().shown_seed(), Some(seed));
}
