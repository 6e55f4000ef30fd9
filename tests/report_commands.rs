//! The report's worst episodes name the command that opens each in the debugger, at the step
//! where it failed.
#![allow(clippy::unwrap_used, reason = "tests fail loudly")]

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
        target_visible_steps: None,
        m_on_target_steps: None,
        counterfactual: None,
    }
}

#[test]
fn a_failed_episode_opens_at_its_last_step() {
    assert_eq!(
        failure("failed", 256).view_command(),
        "groundscope view --checkpoint bundled:attention --room-size 16 --objects 10 --seed 42 --step 255"
    );
    // A success listed for its low acc_cmb has no failing step: it opens at the start.
    assert_eq!(
        failure("low_acc_cmb", 12).view_command(),
        "groundscope view --checkpoint bundled:attention --room-size 16 --objects 10 --seed 42"
    );
}
