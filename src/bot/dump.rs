//! The bot against a dump that carries minigrid's own bot's suggestions
//! (`gen_minigrid_fixtures.py --planner bot --record-bot`): `groundscope env verify` replays
//! such a dump with our bot beside it, told each action taken, and compares its action and
//! its subgoal stack with minigrid's at every step.

use serde_json::{Value, json};

use super::{Bot, Datum, Reason, Subgoal};
use crate::env::{Action, Color, EnvError, Loc, Mismatch, ObjDesc, ObjectKind, Snapshot, World};

fn desc_json(d: ObjDesc) -> Value {
    json!({
        "type": d.kind.map(ObjectKind::name),
        "color": d.color.map(Color::name),
        "loc": d.loc.map(Loc::name),
    })
}

impl Subgoal {
    /// The subgoal as the fixture script writes it: `{"subgoal": class, "datum": null | [x,
    /// y] | {"type", "color", "loc"[, "pos"]}, "reason": null | text}`.
    pub fn dump_json(&self, world: &World) -> Value {
        let datum = match &self.datum {
            None | Some(Datum::Pos(None)) => Value::Null,
            Some(Datum::Pos(Some(p))) => json!([p.0, p.1]),
            Some(Datum::Clause { clause, fixed }) => world
                .instr
                .clauses()
                .get(*clause)
                .and_then(|n| {
                    if *fixed {
                        n.instr.fixed
                    } else {
                        Some(n.instr.desc)
                    }
                })
                .map_or(Value::Null, desc_json),
            Some(Datum::Own { desc, .. }) => desc_json(*desc),
            Some(Datum::Door(p)) => {
                let color = world.grid.get(*p).map(|d| d.color.name());
                json!({"type": "door", "color": color, "loc": null, "pos": [p.0, p.1]})
            }
        };
        json!({
            "subgoal": self.kind.class_name(),
            "datum": datum,
            "reason": self.reason.map(Reason::name),
        })
    }
}

impl Bot {
    /// The stack as the fixture script writes it (`null` once given up).
    pub fn dump_json(&self, world: &World) -> Value {
        if self.gave_up.is_some() {
            return Value::Null;
        }
        Value::Array(self.stack.iter().map(|s| s.dump_json(world)).collect())
    }
}

/// Replays `snap` from its initial state with the bot beside it, told every action taken:
/// `None` when the dump carries no `bot_action`; else the number of steps checked, or the
/// first step at which the bot's action or stack differs from minigrid's (steps count from 1,
/// as [`Mismatch`] does; the bot speaks before the action of that step).
pub fn verify_bot(snap: &Snapshot) -> Result<Option<Result<usize, Mismatch>>, EnvError> {
    if snap.steps.iter().all(|s| s.bot_action.is_none()) {
        return Ok(None);
    }
    let mut world = snap.to_world()?;
    let mut bot = Bot::new(&world);
    let mut taken = None;
    for (i, s) in snap.steps.iter().enumerate() {
        let got = bot.replan(&world, taken);
        let got_stack = bot.dump_json(&world);
        let want = s.bot_action.clone().unwrap_or(Value::Null);
        let want_stack = s.bot_stack.clone().unwrap_or(Value::Null);
        let got_action = got.map_or(Value::Null, |a| json!(a as u8));
        if got_action != want || got_stack != want_stack {
            let why = bot
                .gave_up()
                .map_or_else(String::new, |g| format!(" (ours gave up: {g})"));
            return Ok(Some(Err(Mismatch {
                step: i + 1,
                what: format!(
                    "minigrid's bot suggests {want} with stack {want_stack}, ours {got_action}{why} with stack {got_stack}"
                ),
            })));
        }
        let action = usize::try_from(s.action)
            .ok()
            .and_then(Action::from_index)
            .ok_or_else(|| EnvError::InvalidSnapshot {
                field: format!("steps[{i}].action"),
                reason: format!("{} is not an action index (0–6)", s.action),
            })?;
        if world.ended() {
            break;
        }
        world.step(action)?;
        taken = Some(action);
    }
    Ok(Some(Ok(snap.steps.len())))
}
