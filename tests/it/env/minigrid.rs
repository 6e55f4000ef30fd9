//! MiniGrid's own environments against minigrid 3.2.0: 228 random-action episodes (the 76
//! ids × 3 seeds, replayed step by step through `verify_dump`) and the initial state of
//! seeds 100–199 of every id (`tests/fixtures/minigrid_envs/make.sh` regenerates both).

use crate::common;

use groundscope::env::{LevelConfig, LevelId, Snapshot, World, verify_dump};
use serde_json::Value;

fn episodes() -> Vec<std::path::PathBuf> {
    common::fixtures("minigrid_envs")
        .into_iter()
        .filter(|p| p.to_string_lossy().ends_with(".json.gz"))
        .collect()
}

#[test]
fn every_minigrid_episode_replays_identically() {
    let files = episodes();
    assert_eq!(files.len(), 76 * 3, "the 76 ids × 3 seeds are present");
    let (mut steps, mut ended, mut ids) = (0, 0, std::collections::BTreeSet::new());
    let mut failures = Vec::new();
    for f in &files {
        let text = groundscope::files::read_text_maybe_gz(f).unwrap();
        let snap = Snapshot::from_json(&text).unwrap();
        ids.insert(snap.env_id.clone().unwrap());
        match verify_dump(&snap) {
            Ok(Ok(n)) => {
                steps += n;
                let last = snap.steps.last();
                ended += usize::from(last.is_some_and(|s| s.terminated || s.truncated));
            }
            Ok(Err(m)) => failures.push(format!("{}: step {}: {}", f.display(), m.step, m.what)),
            Err(e) => failures.push(format!("{}: {e}", f.display())),
        }
    }
    assert!(
        failures.is_empty(),
        "{} failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
    assert_eq!(ids.len(), 76);
    // Random actions end episodes on lava, obstacles, wrong pickups and horizons.
    assert!(
        ended > 150 && steps > 20_000,
        "{ended} episodes ended, {steps} steps"
    );
}

fn as_i64s(v: &Value) -> Vec<i64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_i64().unwrap())
        .collect()
}

/// One generated world in the dump's terms: grid, pose, mission, box contents, horizon.
fn state_of(w: &World) -> Value {
    let grid: Vec<Vec<[u8; 3]>> = w.grid.encode();
    let boxes: Vec<Value> = w
        .box_contents
        .iter()
        .filter_map(|(id, inner)| {
            let p = w.grid.find_id(*id)?;
            Some(serde_json::json!([p.0, p.1, inner.encode()]))
        })
        .collect();
    serde_json::json!({
        "grid": grid,
        "agent_pos": [w.agent_pos.0, w.agent_pos.1],
        "agent_dir": w.agent_dir,
        "mission": w.mission,
        "box_contents": boxes,
        "max_steps": w.max_steps,
    })
}

#[test]
fn every_minigrid_id_generates_as_minigrid_on_100_more_seeds() {
    let path = common::fixtures("minigrid_envs")
        .into_iter()
        .find(|p| p.ends_with("generation.jsonl.gz"))
        .unwrap();
    let text = groundscope::files::read_text_maybe_gz(&path).unwrap();
    let mut failures = Vec::new();
    let mut n = 0;
    for line in text.lines() {
        let want: Value = serde_json::from_str(line).unwrap();
        let id = want["env_id"].as_str().unwrap();
        let seed = want["seed"].as_u64().unwrap();
        let level = LevelConfig::babyai(LevelId::parse(id).unwrap(), false);
        let got = state_of(&level.generate(seed).unwrap());
        n += 1;
        for key in ["grid", "agent_dir", "mission", "max_steps"] {
            if got[key] != want[key] {
                failures.push(format!("{id} seed {seed}: {key} differs"));
            }
        }
        if as_i64s(&got["agent_pos"]) != as_i64s(&want["agent_pos"]) {
            failures.push(format!("{id} seed {seed}: agent_pos differs"));
        }
        let boxes = |v: &Value| {
            let mut b: Vec<String> = v.as_array().unwrap().iter().map(Value::to_string).collect();
            b.sort();
            b
        };
        if boxes(&got["box_contents"]) != boxes(&want["box_contents"]) {
            failures.push(format!("{id} seed {seed}: box_contents differ"));
        }
    }
    failures.truncate(40);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!(n, 7600, "76 ids × 100 seeds");
}

#[test]
fn a_class_spelt_with_its_arguments_is_the_registered_id() {
    for (id, class) in [
        (
            "MiniGrid-MultiRoom-N6-v0",
            "MultiRoomEnv(minNumRooms=6, maxNumRooms=6)",
        ),
        (
            "MiniGrid-SimpleCrossingS9N2-v0",
            "CrossingEnv(size=9, num_crossings=2, obstacle_type=wall)",
        ),
        (
            "MiniGrid-ObstructedMaze-2Q-v1",
            "ObstructedMaze_Full_V1(agent_room=(2, 1), num_quarters=2, num_rooms_visited=11)",
        ),
        (
            "MiniGrid-Dynamic-Obstacles-Random-6x6-v0",
            "DynamicObstaclesEnv(size=6, agent_start_pos=None, n_obstacles=3)",
        ),
        ("MiniGrid-Fetch-5x5-N2-v0", "FetchEnv(size=5, numObjs=2)"),
    ] {
        let a = LevelConfig::babyai(LevelId::parse(id).unwrap(), false);
        let b = LevelConfig::babyai(LevelId::parse(class).unwrap(), false);
        for seed in 0..20 {
            assert_eq!(
                a.generate(seed).unwrap(),
                b.generate(seed).unwrap(),
                "{class} seed {seed}"
            );
        }
    }
    // The spelling is canonical: the same arguments name the same level.
    let x = LevelId::parse("MultiRoomEnv(minNumRooms=7,maxNumRooms=7, maxRoomSize=8)").unwrap();
    let y = LevelId::parse("MultiRoomEnv(maxRoomSize=8, minNumRooms=7, maxNumRooms=7)").unwrap();
    assert_eq!(x, y);
    assert_eq!(
        x.id(),
        "MultiRoomEnv(minNumRooms=7, maxNumRooms=7, maxRoomSize=8, width=25, height=25)"
    );
    let w = LevelConfig::babyai(x, false).generate(3).unwrap();
    assert_eq!(w.max_steps, 140);
}

#[test]
fn refused_ids_say_why() {
    let err = |id: &str| LevelId::parse(id).unwrap_err().to_string();
    assert!(err("MiniGrid-WFC-MazeSimple-v0").contains("minigrid itself cannot build it"));
    let near = err("MiniGrid-DoorKey-5x5-v1");
    assert!(near.contains("MiniGrid-DoorKey-5x5-v0"), "{near}");
    let babyai = err("BabyAI-GoToRedBal-v0");
    assert!(babyai.contains("BabyAI-GoToRedBall-v0"), "{babyai}");
    assert!(err("MultiRoomEnv(minNumRooms=3)").contains("maxNumRooms"));
    assert_eq!(LevelId::all().count(), 172);
    assert_eq!(LevelId::minigrid_all().count(), 76);
}
