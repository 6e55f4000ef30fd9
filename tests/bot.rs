//! The bot against minigrid 3.2.0's `BabyAIBot`, action for action: episodes written by the
//! shared `gen_minigrid_fixtures.py --planner bot --record-bot` on every BabyAI id (seeds
//! 0–2, both done modes; `mixed/`: the bot's action taken 80% of the time, a random one
//! otherwise, so the bot must replan around actions it did not choose; `alone/`: the bot
//! alone). Each level is regenerated from its id and seed, the recorded actions are replayed,
//! and at every step our bot — told the action actually taken — must suggest what minigrid's
//! did, hold the same subgoal stack, and give up exactly where minigrid's gave up.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test helpers fail loudly"
)]

mod common;

use std::path::Path;

use groundscope::bot::{Bot, Datum, Subgoal};
use groundscope::env::{Action, ObjDesc, World, babyai};
use serde_json::{Value, json};

fn desc_json(d: &ObjDesc) -> Value {
    json!({
        "type": d.kind.map(|k| k.name()),
        "color": d.color.map(|c| c.name()),
        "loc": d.loc.map(|l| l.name()),
    })
}

/// A subgoal as the fixture script writes it.
fn subgoal_json(world: &World, s: &Subgoal) -> Value {
    let datum = match &s.datum {
        None | Some(Datum::Pos(None)) => Value::Null,
        Some(Datum::Pos(Some(p))) => json!([p.0, p.1]),
        Some(Datum::Clause { clause, fixed }) => {
            let n = world.instr.clauses()[*clause];
            desc_json(&if *fixed {
                n.instr.fixed.unwrap()
            } else {
                n.instr.desc
            })
        }
        Some(Datum::Own { desc, .. }) => desc_json(desc),
        Some(Datum::Door(p)) => {
            let door = world.grid.get(*p).unwrap();
            json!({"type": "door", "color": door.color.name(), "loc": null, "pos": [p.0, p.1]})
        }
    };
    json!({
        "subgoal": s.kind.class_name(),
        "datum": datum,
        "reason": s.reason.map(|r| r.name()),
    })
}

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
        let got_stack = if bot.gave_up().is_some() {
            Value::Null
        } else {
            Value::Array(
                bot.stack()
                    .iter()
                    .map(|s| subgoal_json(&world, s))
                    .collect(),
            )
        };
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
