//! The bot against minigrid 3.2.0's `BabyAIBot`, action for action: episodes written by the
//! shared `gen_minigrid_fixtures.py --planner bot --record-bot` on every BabyAI id (seeds
//! 0–2, both done modes; `mixed/`: the bot's action taken 80% of the time, a random one
//! otherwise, so the bot must replan around actions it did not choose; `alone/`: the bot
//! alone). Each level is regenerated from its id and seed, the recorded actions are replayed,
//! and at every step our bot — told the action actually taken — must suggest what minigrid's
//! did, hold the same subgoal stack, and give up exactly where minigrid's gave up.

use crate::common;

use std::path::Path;

use groundscope::bot::Bot;
use groundscope::env::{Action, babyai};
use serde_json::Value;

/// Replays one dump; the first step where the bot differs, if any.
fn replay(path: &Path) -> Result<usize, String> {
    let text = groundscope::files::read_text_maybe_gz(path).map_err(|e| e.to_string())?;
    let d: Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
    let id = d["env_id"].as_str().unwrap();
    let seed = d["seed"].as_u64().unwrap();
    let done = d["done_actions"].as_bool().unwrap();
    let mut world = babyai::generate(babyai::spec(id).unwrap(), seed, done).unwrap();
    let mut bot = Bot::new(&world);
    let mut taken = None;
    let steps = d["steps"].as_array().unwrap();
    for (t, step) in steps.iter().enumerate() {
        let got = bot.replan(&world, taken);
        let want = step["bot_action"].as_u64().map(|a| a as usize);
        let got_stack = bot.dump_json(&world);
        if got.map(|a| a as usize) != want || got_stack != step["bot_stack"] {
            return Err(format!(
                "step {t}: minigrid's bot suggests {want:?} with stack {}, ours {got:?} ({}) with stack {got_stack}",
                step["bot_stack"],
                bot.gave_up()
                    .map_or("planning".to_string(), ToString::to_string),
            ));
        }
        let a = Action::from_index(step["action"].as_u64().unwrap() as usize).unwrap();
        world.step(a).unwrap();
        taken = Some(a);
    }
    Ok(steps.len())
}

fn check_set(set: &str) -> usize {
    let files = common::fixtures(set);
    assert!(files.len() >= 192, "{set}: only {} fixtures", files.len());
    common::for_each_fixture(set, |p| replay(p).map(|_| ()))
}

#[test]
fn the_bot_alone_acts_as_minigrids() {
    check_set("bot/alone");
}

#[test]
fn the_bot_replans_around_random_actions_as_minigrids() {
    check_set("bot/mixed");
}

/// `env verify` checks a dump's `bot_action` and `bot_stack` too: it passes the fixtures and
/// names the step where a suggestion was changed.
#[test]
fn env_verify_checks_the_bots_suggestions() {
    let files = common::fixtures("bot/mixed");
    let some: Vec<&str> = files
        .iter()
        .step_by(97)
        .map(|p| p.to_str().unwrap())
        .collect();
    let mut args = vec!["env", "verify"];
    args.extend(&some);
    let o = common::gs(&args);
    assert!(
        o.status.success(),
        "{}{}",
        common::stdout(&o),
        common::stderr(&o)
    );
    assert!(common::stdout(&o).contains(&format!("{} passed, 0 failed", some.len())));

    let text = groundscope::files::read_text_maybe_gz(&files[0]).unwrap();
    let mut d: Value = serde_json::from_str(&text).unwrap();
    let step = d["steps"]
        .as_array()
        .unwrap()
        .iter()
        .position(|s| s["bot_action"].is_u64())
        .unwrap();
    let a = d["steps"][step]["bot_action"].as_u64().unwrap();
    d["steps"][step]["bot_action"] = (a ^ 1).into();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("changed.json");
    std::fs::write(&path, d.to_string()).unwrap();
    let o = common::gs(&["env", "verify", path.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", common::stderr(&o));
    let out = common::stdout(&o);
    assert!(
        out.contains(&format!(
            "step {}: minigrid's bot suggests {}",
            step + 1,
            a ^ 1
        )),
        "{out}"
    );
}

/// The fixtures cover what the port must get right: giving up, every subgoal class and
/// every reason, and both done modes.
#[test]
fn the_fixtures_cover_every_subgoal_and_giving_up() {
    let mut seen = std::collections::BTreeSet::new();
    let mut gave_up = 0;
    for set in ["bot/alone", "bot/mixed"] {
        for f in common::fixtures(set) {
            let d: Value =
                serde_json::from_str(&groundscope::files::read_text_maybe_gz(&f).unwrap()).unwrap();
            seen.insert(format!("done {}", d["done_actions"]));
            for s in d["steps"].as_array().unwrap() {
                match s["bot_stack"].as_array() {
                    None => gave_up += 1,
                    Some(stack) => {
                        for g in stack {
                            seen.insert(g["subgoal"].as_str().unwrap().to_string());
                            if let Some(r) = g["reason"].as_str() {
                                seen.insert(r.to_string());
                            }
                        }
                    }
                }
            }
        }
    }
    for want in [
        "CloseSubgoal",
        "OpenSubgoal",
        "DropSubgoal",
        "PickupSubgoal",
        "GoNextToSubgoal",
        "ExploreSubgoal",
        "Open",
        "PutNext",
        "Explore",
        "Unlock",
        "done true",
        "done false",
    ] {
        assert!(seen.contains(want), "no fixture step has {want}: {seen:?}");
    }
    assert!(gave_up > 0, "no fixture step where minigrid's bot gave up");
}
