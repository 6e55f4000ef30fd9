//! `view --report DIR` (issue #66): an evaluation's episodes browsed in the debugger — read
//! back, filtered, sorted, stepped failure to failure and opened where each was lost — a
//! Python policy's replayed read-only, and the bad reports refused in one line.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use crate::common::debugger::{build, show_until};
use crate::common::{self, assert_bad_input, gs, stderr};
use eframe::egui;
use egui_kittest::kittest::Queryable as _;
use groundscope::app::Launch;
use groundscope::app::episodes::{Browser, Column, Divergence, Outcome};
use groundscope::metrics::report::browse::read_only_line;

/// An evaluation of an untrained model (which fails) and `bundled:babyai` (which mostly
/// succeeds) on two levels, 4 episodes each: made once, shared by the tests.
fn report() -> &'static Path {
    static DIR: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let ckpt = dir.path().join("fresh");
        let o = gs(&[
            "init",
            "--level",
            "BabyAI-GoToLocal-v0",
            "--out",
            ckpt.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = dir.path().join("report");
        let o = gs(&[
            "eval",
            "--checkpoint",
            ckpt.to_str().unwrap(),
            "--checkpoint",
            "bundled:babyai",
            "--levels",
            "BabyAI-GoToLocal-v0,BabyAI-GoToDoor-v0",
            "--seeds",
            "1",
            "--episodes",
            "4",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        (dir, out)
    })
    .1
}

#[test]
fn a_report_reads_back_filters_sorts_and_steps_failure_to_failure() {
    let mut b = Browser::open(report()).unwrap();
    assert_eq!(b.report.rows.len(), 16);
    assert!(!b.report.sample);
    assert_eq!(
        b.values(Column::Level),
        ["BabyAI-GoToDoor-v0", "BabyAI-GoToLocal-v0"]
    );
    let failures = b.report.rows.iter().filter(|r| !r.success).count();
    assert!(failures > 0 && failures < 16, "{failures} failures");
    // Failures only, longest first.
    b.filter.outcome = Outcome::Failures;
    b.refresh();
    assert_eq!(b.shown().len(), failures);
    b.sort_by(Column::Steps);
    b.sort_by(Column::Steps);
    let steps: Vec<u32> = b.shown().iter().map(|&i| b.report.rows[i].steps).collect();
    assert!(steps.windows(2).all(|w| w[0] >= w[1]), "{steps:?}");
    // N walks the failures in the order listed and wraps round; P walks back.
    let order = b.shown().to_vec();
    let walked: Vec<usize> = (0..=order.len())
        .map(|_| b.step_failure(true).unwrap())
        .collect();
    assert_eq!(walked[..order.len()], order[..]);
    assert_eq!(walked[order.len()], order[0]);
    if order.len() > 1 {
        assert_eq!(b.step_failure(false), Some(order[order.len() - 1]));
    }
    // One level, never diverged: each filter narrows what the last one let through.
    b.filter = groundscope::app::episodes::Filter {
        level: Some("BabyAI-GoToDoor-v0".into()),
        divergence: Divergence::Never,
        ..Default::default()
    };
    b.refresh();
    assert!(b.shown().iter().all(|&i| {
        let r = &b.report.rows[i];
        r.level == "BabyAI-GoToDoor-v0" && r.first_divergence.is_none()
    }));
    // A failure opens with its checkpoint, level, seed and the step where it was lost.
    let f = b.report.rows.iter().position(|r| !r.success).unwrap();
    let ep = b.episode(f).unwrap();
    let row = &b.report.rows[f];
    assert_eq!(ep.seed, row.level_seed);
    assert_eq!(ep.level.id(), row.level);
    assert!(!ep.level.done_required);
    assert_eq!(ep.step as u32, row.decisive_step.unwrap());
    assert!(groundscope::policy::Agent::load(&ep.checkpoint).is_ok());
}

/// The debugger opens the report at its first failure, lists its episodes, and N opens the
/// next failure at the step where it was lost.
#[test]
fn the_debugger_browses_a_report_and_opens_the_next_failure() {
    let mut b = Browser::open(report()).unwrap();
    let first = b.first().unwrap();
    let ep = b.episode(first).unwrap();
    b.selected = Some(first);
    let rows = &b.report.rows;
    let failed: Vec<usize> = (0..rows.len()).filter(|&i| !rows[i].success).collect();
    let mut h = build(&Launch {
        report: Some(b.clone()),
        ..Launch::new(ep.clone())
    });
    show_until(&mut h, &format!("step {} of ", ep.step));
    h.get_by_label_contains("16 of 16 episodes listed");
    assert!(failed.len() >= 2, "{} failures", failed.len());
    h.key_press(egui::Key::N);
    let next = b.step_failure(true).unwrap();
    let want = b.episode(next).unwrap();
    assert_eq!(next, failed[1]);
    show_until(&mut h, &format!("step {} of ", want.step));
    wait_for_seed(&mut h, want.seed);
}

/// A click on a row opens that episode and folds the docked list to its one line, which lies
/// above the world panel, never over it (issue #83: the list was a window over the step it
/// opened, and stayed there).
#[test]
fn picking_an_episode_folds_the_docked_list_off_the_world() {
    let mut b = Browser::open(report()).unwrap();
    let first = b.first().unwrap();
    let ep = b.episode(first).unwrap();
    b.selected = Some(first);
    let mut h = build(&Launch {
        report: Some(b.clone()),
        ..Launch::new(ep.clone())
    });
    show_until(&mut h, &format!("step {} of ", ep.step));
    h.get_by_label_contains("16 of 16 episodes listed");
    // The row after the one open: the list opens scrolled to the row open, and the rows beside
    // it hold other seeds, so the first cell on screen with its seed is its own.
    let at = b.shown().iter().position(|&i| i == first).unwrap();
    let pick = *b
        .shown()
        .get(at + 1)
        .expect("a row after the first failure");
    let want = b.episode(pick).unwrap();
    assert_ne!(want.seed, ep.seed);
    h.query_all_by_label(&want.seed.to_string())
        .next()
        .expect("the row's seed cell")
        .click();
    wait_for_seed(&mut h, want.seed);
    show_until(&mut h, &format!("step {} of ", want.step));
    // Folded: neither the rows nor the filters; the panel's line above the world, which is
    // whole in the window.
    assert!(h.query_by_label_contains("episodes listed").is_none());
    assert!(h.query_by_label("diverged from the bot").is_none());
    let line = h.get_by_label("episodes").rect();
    let world = h.get_by_label("world picture").rect();
    assert!(
        line.max.y <= world.min.y,
        "the panel's line {line:?} over the world {world:?}"
    );
    assert!(world.max.y <= 900.0 && world.max.x <= 1400.0, "{world:?}");
}

/// The top bar's "report…" opens a report (an empty field is an error naming the file it
/// looked for); the episodes panel then lists it.
#[test]
fn the_report_button_opens_an_evaluation() {
    let agent = groundscope::app::session::Agent::load("bundled:babyai").unwrap();
    let mut h = build(&Launch::new(groundscope::app::EpisodeRequest::new(
        "bundled:babyai",
        agent.level(),
        0,
    )));
    show_until(&mut h, "step 0 of ");
    assert!(h.query_by_label("episodes").is_none());
    h.get_by_label("report…").click();
    show_until(&mut h, "episodes.csv");
    h.state_mut().open_report(report());
    show_until(&mut h, "16 of 16 episodes listed");
    h.get_by_label("episodes");
}

/// A report as `groundscope.evaluate` writes it for a Python policy named `name`: the files of
/// the writer the Python binding calls (here through `eval` of `bundled:babyai`, whose episodes
/// a callable could have taken), its checkpoint renamed `name`, with neither frames nor level,
/// and marked `python` in `report.json`.
fn python_report(name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let o = gs(&[
        "eval",
        "--checkpoint",
        "bundled:babyai",
        "--levels",
        "BabyAI-GoToLocal-v0",
        "--seeds",
        "1",
        "--episodes",
        "3",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json = out.join("report.json");
    let mut report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let ckpt = &mut report["checkpoints"][0];
    ckpt["name"] = name.into();
    ckpt["python"] = true.into();
    ckpt["frames"] = serde_json::Value::Null;
    ckpt["level"] = serde_json::Value::Null;
    std::fs::write(&json, report.to_string()).unwrap();
    let csv = out.join("episodes.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.contains("\nbundled:babyai,"), "{text}");
    std::fs::write(
        &csv,
        text.replace("\nbundled:babyai,", &format!("\n{name},")),
    )
    .unwrap();
    (dir, out)
}

/// A Python policy's report opens read-only (issues #81 and #83): its episode is replayed from
/// the report's level, seed and actions, step for step as the evaluation ran it, under the one
/// line that says so; nothing is loaded — a policy named `bot` does not open minigrid's bot —
/// and a probe, with no policy to re-run, is refused. `view --report` used to fail on
/// "checkpoint python: python.json: No such file or directory", or open the bot.
#[test]
fn a_python_policys_report_opens_read_only_and_never_as_the_bot() {
    for name in ["bot", "python"] {
        let (_dir, out) = python_report(name);
        let b = Browser::open(&out).unwrap();
        let first = b.first().unwrap();
        assert!(b.is_python(first), "{name}");
        assert!(
            b.episode(first).is_err(),
            "{name}: never re-run as a checkpoint"
        );
        let row = b.report.rows[first].clone();
        let launch = Launch::from_report(b).unwrap();
        assert_eq!(launch.request.checkpoint, "", "{name}: nothing to load");
        assert_eq!(launch.request.seed, row.level_seed);
        let mut h = build(&launch);
        show_until(&mut h, &read_only_line(name));
        let s = h.state().session();
        assert!(s.agent.is_none(), "{name}: an agent was loaded");
        assert_eq!(s.read_only.as_deref(), Some(name));
        let shown = s.shown.as_ref().expect("the episode replayed");
        let trace = &shown.trace;
        assert_eq!(trace.checkpoint, format!("python policy '{name}'"));
        assert_eq!(trace.seed, row.level_seed);
        assert_eq!(trace.steps.len(), row.steps as usize, "{name}");
        assert_eq!(trace.success(), row.success, "{name}");
        let actions: Vec<String> = trace
            .steps
            .iter()
            .map(|s| (s.action as usize).to_string())
            .collect();
        assert_eq!(
            actions.join(" "),
            row.actions,
            "{name}: the report's actions"
        );
        assert!(trace.steps.iter().all(|s| s.attention.is_none()));
        assert_eq!(s.cursor.step, row.open_step());
        h.get_by_label_contains(&format!("shown: python policy '{name}'"));
        // No policy to re-run from an edited step.
        h.state_mut().session_mut().turn(1);
        let e = h.state().last_error().unwrap_or_default().to_owned();
        assert!(e.contains("read-only"), "{name}: {e}");
        assert!(!h.state().session().busy(), "{name}: a probe was started");
    }
}

/// Runs frames until the debugger shows seed `seed`'s episode.
fn wait_for_seed(h: &mut egui_kittest::Harness<'_, groundscope::app::Debugger>, seed: u64) {
    common::wait_until(&format!("seed {seed} shown"), || {
        h.step();
        h.state().shown_seed() == Some(seed)
    });
}

#[test]
fn a_report_that_cannot_open_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let o = gs(&["view", "--report", dir.path().to_str().unwrap()]);
    assert_bad_input(&o, "episodes.csv");
    // A level no version wrote, named by line and column.
    let bad = dir.path().join("bad");
    std::fs::create_dir(&bad).unwrap();
    let text = std::fs::read_to_string(report().join("episodes.csv")).unwrap();
    let broken = text.replacen("BabyAI-GoToLocal-v0", "BabyAI-GoToLocl-v0", 1);
    std::fs::write(bad.join("episodes.csv"), broken).unwrap();
    let o = gs(&["view", "--report", bad.to_str().unwrap()]);
    assert_bad_input(&o, "column level");
    // An episode names itself: --report does not take another episode's flags.
    let o = gs(&[
        "view",
        "--report",
        report().to_str().unwrap(),
        "--seed",
        "3",
    ]);
    assert_bad_input(&o, "--seed");
}
