//! Replay checks: a dump's actions replayed from its initial state and compared, step by
//! step, with what Python recorded.

use super::{Snapshot, ascii_grid, encode_i64, invalid, obs_to_i64, u8_in};
use crate::env::error::EnvError;
use crate::env::world::Action;

/// The first difference between a replay and its dump.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mismatch {
    /// 1-based step (0 = the initial state).
    pub step: usize,
    /// What differed, with expected and actual values.
    pub what: String,
}

/// Checks that an observation image in a dump is 7×7 cells of three codes each, every code
/// in MiniGrid's ranges, so that a malformed dump is bad input rather than a mismatch.
fn check_image(image: &[Vec<Vec<i64>>], field: &str) -> Result<(), EnvError> {
    if image.len() != 7 || image.iter().any(|col| col.len() != 7) {
        return Err(invalid(field, "an observation image must be 7×7 cells"));
    }
    for (x, col) in image.iter().enumerate() {
        for (y, cell) in col.iter().enumerate() {
            let f = || format!("{field}[{x}][{y}]");
            let [t, c, s] = cell.as_slice() else {
                return Err(invalid(
                    f(),
                    format!("expected 3 codes, got {}", cell.len()),
                ));
            };
            u8_in(*t, 10, f)?;
            u8_in(*c, 5, f)?;
            u8_in(*s, 2, f)?;
        }
    }
    Ok(())
}

/// Replays a dump's actions from its initial state and compares every observation, reward,
/// flag, pose, carried object and changed grid; returns the first mismatch, or the number
/// of steps checked. Invalid dumps are errors.
pub fn verify_dump(snap: &Snapshot) -> Result<Result<usize, Mismatch>, EnvError> {
    let mut world = snap.to_world()?;
    if let Some(obs) = &snap.initial_obs {
        check_image(&obs.image, "initial_obs.image")?;
    }
    for (i, s) in snap.steps.iter().enumerate() {
        check_image(&s.image, &format!("steps[{i}].image"))?;
    }
    if let Some(obs) = &snap.initial_obs {
        if obs.direction != i64::from(world.agent_dir) {
            return Ok(Err(Mismatch {
                step: 0,
                what: format!(
                    "initial_obs.direction: expected {}, got {}",
                    obs.direction, world.agent_dir
                ),
            }));
        }
        if obs.mission != world.mission {
            return Ok(Err(Mismatch {
                step: 0,
                what: format!(
                    "initial_obs.mission: expected {:?}, got {:?}",
                    obs.mission, world.mission
                ),
            }));
        }
        let got = obs_to_i64(&world.observe());
        if got != obs.image {
            return Ok(Err(Mismatch {
                step: 0,
                what: format!(
                    "initial observation differs: expected {:?}, got {got:?}",
                    obs.image
                ),
            }));
        }
    }
    let ascii = ascii_grid(&world.grid, world.agent_pos, world.agent_dir);
    if !snap.grid_ascii.is_empty() && snap.grid_ascii != ascii {
        return Ok(Err(Mismatch {
            step: 0,
            what: format!(
                "grid_ascii differs: expected {:?}, got {ascii:?}",
                snap.grid_ascii
            ),
        }));
    }
    for (i, s) in snap.steps.iter().enumerate() {
        let t = i + 1;
        let field = format!("steps[{i}].action");
        let action = usize::try_from(s.action)
            .ok()
            .and_then(Action::from_index)
            .ok_or_else(|| invalid(field, format!("{} is not an action (0..=6)", s.action)))?;
        if world.ended() {
            return Ok(Err(Mismatch {
                step: t,
                what: "the dump continues after the episode ended".into(),
            }));
        }
        let out = world.step(action)?;
        let mismatch = |what: String| Ok(Err(Mismatch { step: t, what }));
        let image = obs_to_i64(&world.observe());
        if image != s.image {
            return mismatch(format!(
                "observation differs after {action}: expected {:?}, got {image:?}",
                s.image
            ));
        }
        if out.reward != s.reward {
            return mismatch(format!("reward: expected {}, got {}", s.reward, out.reward));
        }
        if out.terminated != s.terminated || out.truncated != s.truncated {
            return mismatch(format!(
                "terminated/truncated: expected {}/{}, got {}/{}",
                s.terminated, s.truncated, out.terminated, out.truncated
            ));
        }
        let pos = [i64::from(world.agent_pos.0), i64::from(world.agent_pos.1)];
        if pos != s.agent_pos || i64::from(world.agent_dir) != s.agent_dir {
            return mismatch(format!(
                "agent pose: expected {:?} dir {}, got {pos:?} dir {}",
                s.agent_pos, s.agent_dir, world.agent_dir
            ));
        }
        if s.direction != i64::from(world.agent_dir) {
            return mismatch(format!(
                "observation direction: expected {}, got {}",
                s.direction, world.agent_dir
            ));
        }
        if i64::from(world.step_count) != s.step_count {
            return mismatch(format!(
                "step_count: expected {}, got {}",
                s.step_count, world.step_count
            ));
        }
        let carrying = world.carrying.map(|c| {
            let e = c.encode();
            [i64::from(e[0]), i64::from(e[1]), i64::from(e[2])]
        });
        if carrying != s.carrying {
            return mismatch(format!(
                "carrying: expected {:?}, got {carrying:?}",
                s.carrying
            ));
        }
        if let Some(g) = &s.grid {
            let got: Vec<Vec<Vec<i64>>> = world
                .grid
                .encode()
                .into_iter()
                .map(|col| col.into_iter().map(encode_i64).collect())
                .collect();
            if &got != g {
                return mismatch("world grid differs".into());
            }
        }
    }
    Ok(Ok(snap.steps.len()))
}
