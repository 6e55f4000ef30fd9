//! Replay checks: a dump's actions replayed from its initial state and compared, step by
//! step, with what Python recorded.

use super::{
    Snapshot, ascii_grid, box_contents_json, encode_i64, instr_to_json, invalid, obs_to_i64, u8_in,
};
use crate::env::babyai;
use crate::env::error::{EnvError, shown};
use crate::env::level::PAPER_PREFIX;
use crate::env::world::Action;

/// The minigrid version the port follows; dumps of another version are refused.
pub const MINIGRID_VERSION: &str = "3.2.0";

/// How a snapshot that groundscope wrote (`env show --snapshot`) names its producer in
/// `minigrid_version`: `groundscope 0.1.0`. Its levels are the port's, which follows
/// [`MINIGRID_VERSION`], so such a snapshot is checked as a dump of that version.
pub const PRODUCER_PREFIX: &str = "groundscope ";

/// Regenerates a dump's level from its `env_id` and `seed` (a registered `BabyAI-*` id) and
/// compares the initial state: size, grid, box contents, agent pose, carried object,
/// horizon, mission and instruction tree with every matched position. `None` when they agree
/// or the dump names no BabyAI level (a groundscope snapshot); an unknown id, a missing seed
/// or another minigrid version is bad input.
pub fn verify_generation(snap: &Snapshot) -> Result<Option<Mismatch>, EnvError> {
    let Some(id) = snap.env_id.as_deref().filter(|id| {
        id.starts_with("BabyAI-") || id.starts_with("MiniGrid-") || id.starts_with(PAPER_PREFIX)
    }) else {
        return Ok(None);
    };
    if let Some(v) = snap.minigrid_version.as_deref()
        && v != MINIGRID_VERSION
        && !v.starts_with(PRODUCER_PREFIX)
    {
        return Err(invalid(
            "minigrid_version",
            format!(
                "{}: only dumps of minigrid {MINIGRID_VERSION} can be checked",
                shown(v)
            ),
        ));
    }
    let paper = paper_spec(id)?;
    let registered = crate::env::LevelId::parse(id)
        .ok()
        .map(crate::env::LevelId::spec);
    let spec = paper.as_ref().or(registered).ok_or_else(|| {
        invalid(
            "env_id",
            format!(
                "{} is not a level of minigrid {MINIGRID_VERSION} (closest: {})",
                shown(id),
                babyai::closest_ids(id).join(", ")
            ),
        )
    })?;
    let seed = snap
        .seed
        .ok_or_else(|| invalid("seed", "a BabyAI dump needs its seed to be regenerated"))?;
    if snap.step_count != 0 {
        return Err(invalid(
            "step_count",
            "only a dump of a reset level can be regenerated",
        ));
    }
    let world = babyai::generate(spec, seed, snap.done_actions)?;
    let fresh = Snapshot::from_world(&world, snap.env_id.clone(), Some(seed));
    let differ = |what: &str, want: String, got: String| {
        Some(Mismatch {
            step: 0,
            what: format!(
                "regenerated {id} seed {seed}: {what}: the dump has {want}, groundscope made {got}"
            ),
        })
    };
    if (fresh.width, fresh.height) != (snap.width, snap.height) {
        return Ok(differ(
            "grid size",
            format!("{}×{}", snap.width, snap.height),
            format!("{}×{}", fresh.width, fresh.height),
        ));
    }
    for (x, (a, b)) in snap.grid.iter().zip(&fresh.grid).enumerate() {
        for (y, (ca, cb)) in a.iter().zip(b).enumerate() {
            if ca != cb {
                return Ok(differ(
                    &format!("grid[{x}][{y}]"),
                    format!("{ca:?}"),
                    format!("{cb:?}"),
                ));
            }
        }
    }
    if fresh.agent_pos != snap.agent_pos || fresh.agent_dir != snap.agent_dir {
        return Ok(differ(
            "agent pose",
            format!("{:?} dir {}", snap.agent_pos, snap.agent_dir),
            format!("{:?} dir {}", fresh.agent_pos, fresh.agent_dir),
        ));
    }
    if fresh.carrying != snap.carrying {
        return Ok(differ(
            "carrying",
            format!("{:?}", snap.carrying),
            format!("{:?}", fresh.carrying),
        ));
    }
    let boxes = box_contents_json(&world);
    if boxes != snap.box_contents {
        return Ok(differ(
            "box_contents",
            format!("{:?}", snap.box_contents),
            format!("{boxes:?}"),
        ));
    }
    if fresh.mission != snap.mission {
        return Ok(differ(
            "mission",
            format!("{:?}", snap.mission),
            format!("{:?}", fresh.mission),
        ));
    }
    let tree = world.rules.is_none().then(|| instr_to_json(&world.instr));
    let same = match (&tree, &snap.instr) {
        (Some(a), Some(b)) => same_tree(a, b),
        (None, None) => true,
        _ => false,
    };
    if !same {
        return Ok(differ(
            "instruction tree",
            serde_json::to_string(&snap.instr).unwrap_or_default(),
            serde_json::to_string(&tree).unwrap_or_default(),
        ));
    }
    if fresh.max_steps != snap.max_steps {
        return Ok(differ(
            "max_steps",
            snap.max_steps.to_string(),
            fresh.max_steps.to_string(),
        ));
    }
    Ok(None)
}

/// The spec of a paper-level id, `None` for other ids.
fn paper_spec(id: &str) -> Result<Option<babyai::LevelSpec>, EnvError> {
    crate::env::LevelConfig::paper_from_id(id)
        .transpose()
        .map(|c| c.map(|cfg| cfg.spec()))
        .map_err(|reason| invalid("env_id", reason))
}

/// Two instruction trees agree in kind, descriptions, strictness and matched positions (a
/// dump writes `strict` only where the Python class has it and `type: null` explicitly).
fn same_tree(a: &super::InstrJson, b: &super::InstrJson) -> bool {
    let same_desc = |x: &super::DescJson, y: &super::DescJson| {
        x.kind_name == y.kind_name
            && x.color == y.color
            && x.loc == y.loc
            && x.match_positions == y.match_positions
    };
    let parts = |x: &Option<Box<super::InstrJson>>, y: &Option<Box<super::InstrJson>>| match (x, y)
    {
        (Some(x), Some(y)) => same_tree(x, y),
        (None, None) => true,
        _ => false,
    };
    let descs = |x: &Option<super::DescJson>, y: &Option<super::DescJson>| match (x, y) {
        (Some(x), Some(y)) => same_desc(x, y),
        (None, None) => true,
        _ => false,
    };
    a.kind == b.kind
        && a.kind_name == b.kind_name
        && a.color == b.color
        && a.loc == b.loc
        && a.match_positions == b.match_positions
        && a.strict.unwrap_or(false) == b.strict.unwrap_or(false)
        && descs(&a.moved, &b.moved)
        && descs(&a.fixed, &b.fixed)
        && parts(&a.a, &b.a)
        && parts(&a.b, &b.b)
}

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
    // A malformed dump is bad input before it is a mismatch.
    let mut world = snap.to_world()?;
    if let Some(obs) = &snap.initial_obs {
        check_image(&obs.image, "initial_obs.image")?;
    }
    for (i, s) in snap.steps.iter().enumerate() {
        check_image(&s.image, &format!("steps[{i}].image"))?;
    }
    if let Some(m) = verify_generation(snap)? {
        return Ok(Err(m));
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
        if let Some(b) = &s.box_contents {
            let got = box_contents_json(&world);
            if &got != b {
                return mismatch(format!("box contents: expected {b:?}, got {got:?}"));
            }
        }
    }
    Ok(Ok(snap.steps.len()))
}
