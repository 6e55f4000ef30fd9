//! The debugger: what its panels show and how they respond, through egui's test harness
//! (`egui_kittest`, reading the UI's AccessKit tree); a real frame rendered under Xvfb; and its
//! errors.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::format_collect,
    reason = "tests fail loudly"
)]

mod common;

use std::process::{Command, Output};

use eframe::egui;
use egui::accesskit::Toggled;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT as _, Queryable as _};
use groundscope::app::session::{Agent, Request, Shown, run_request};
use groundscope::app::{Debugger, StartOptions};
use groundscope::episode::ActionMode;
use groundscope::metrics::faithfulness::annotate_step;

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

/// [`debugger`] for `checkpoint` (and `compare`, side by side).
fn debugger_of(
    checkpoint: &str,
    compare: Option<&str>,
    step: usize,
    faithfulness: bool,
) -> Harness<'static, Debugger> {
    let opts = StartOptions {
        checkpoint: checkpoint.into(),
        compare: compare.map(str::to_owned),
        level: None,
        seed: 3,
        sample: false,
        step,
        mission: None,
        faithfulness,
    };
    Harness::builder()
        .with_size([1400.0, 1100.0])
        // The harness would also fail on the inputs without an accessible name (the
        // controls' combo boxes, drag values and text fields): not what these tests are about.
        .with_accessibility_check(false)
        .build_ui_state(
            |ui, d: &mut Debugger| d.frame(ui),
            Debugger::new(&opts, None),
        )
}

/// Runs frames until a label containing `text` shows (the episode runs in the background).
fn show_until(h: &mut Harness<'_, Debugger>, text: &str) {
    common::wait_until(&format!("a label with {text:?}"), || {
        h.step();
        // Compare mode shows a second policy panel: any match will do.
        h.query_all_by_label_contains(text).next().is_some()
    });
}

/// The episode the debugger runs, run here without it.
fn episode() -> (Agent, Shown) {
    let agent = Agent::load("bundled:attention").unwrap();
    let request = Request {
        level: agent.level(),
        seed: 3,
        mode: ActionMode::Greedy,
        mission: None,
    };
    let shown = run_request(&agent, &request, 0.5).unwrap();
    (agent, shown)
}

/// The labels of the policy panel for step `k` of `shown`.
fn policy_labels(shown: &Shown, k: usize) -> [String; 2] {
    let step = &shown.trace.steps[k];
    [
        format!(
            "step {k} of {} · {} · total reward {:.3}",
            shown.len(),
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
    for label in ["combined M", "word weights w", "agent view (agent-up)"] {
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
        h.get_by_label_contains(&format!("{name}: TV {:.3}", e.tv));
    }
    for probe in ["M uniform", "M steered to a distractor"] {
        h.get_by_label(probe);
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
    let request = Request {
        level: agent.level(),
        seed: 3,
        mode: ActionMode::Greedy,
        mission: None,
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
