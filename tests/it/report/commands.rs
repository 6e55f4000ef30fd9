//! The report's worst episodes name the command that opens each in the debugger, at the step
//! where it was lost.

use crate::common::{gs, stderr};
use groundscope::metrics::report::Failure;

fn failure(kind: &str, length: u32) -> Failure {
    Failure {
        kind: kind.to_owned(),
        checkpoint: "bundled:attention".to_owned(),
        size: 16,
        objects: 10,
        seed: 42,
        mission: "go to the red ball".to_owned(),
        reward: 0.0,
        length,
        acc_cmb: None,
        replay: "groundscope replay --checkpoint bundled:attention --room-size 16 --objects 10 --seed 42".to_owned(),
        class: None,
        behaviour: None,
        target_visible_steps: None,
        m_on_target_steps: None,
        counterfactual: None,
        counterfactual_skipped: None,
        level: None,
        done_required: Some(true),
        decisive_step: None,
    }
}

#[test]
fn a_failed_episode_opens_at_its_decisive_step_else_its_last() {
    assert_eq!(
        failure("failed", 256).view_command(),
        "groundscope view --checkpoint bundled:attention --room-size 16 --objects 10 --seed 42 --step 255"
    );
    // Where the episode was lost is known: it opens there.
    let lost = Failure {
        decisive_step: Some(17),
        ..failure("failed", 256)
    };
    assert!(lost.view_command().ends_with("--seed 42 --step 17"));
    // A success listed for its low acc_cmb has no failing step: it opens at the start.
    assert_eq!(
        failure("low_acc_cmb", 12).view_command(),
        "groundscope view --checkpoint bundled:attention --room-size 16 --objects 10 --seed 42"
    );
}

#[test]
fn a_one_seed_one_size_report_reads_right() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let o = gs(&[
        "eval",
        "--sizes",
        "8",
        "--objects",
        "4",
        "--seeds",
        "1",
        "--episodes",
        "5",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    // One seed is not "1 seeds", and its "± 0.000" is said to be no std.
    assert!(md.contains("1 seed (from 0)"), "{md}");
    assert!(!md.contains("1 seeds"), "{md}");
    assert!(md.contains("one seed, so no std"), "{md}");
    assert!(!md.contains("± 0.000"), "no std printed for one seed: {md}");
    // Each listed episode can be opened in the debugger.
    assert!(md.contains("`groundscope view --checkpoint "), "{md}");
    // One room size alone still gets a figure wide enough for its title.
    let fig = image::open(out.join("fig6_success.png")).unwrap();
    assert!(fig.width() >= 680, "{}", fig.width());
}
