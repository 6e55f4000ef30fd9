//! The world against 210 episode dumps of minigrid 3.2.0 (7 levels × 2 done modes × 15 seeds).

use crate::common;

use groundscope::env::{Snapshot, verify_dump};

#[test]
fn every_python_dump_replays_identically() {
    let n = common::for_each_fixture("minigrid", |path| {
        let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
        let snap = Snapshot::from_json(&text).map_err(|e| e.to_string())?;
        match verify_dump(&snap).map_err(|e| e.to_string())? {
            Ok(steps) if steps == snap.steps.len() => Ok(()),
            Ok(steps) => Err(format!("replayed {steps} of {} steps", snap.steps.len())),
            Err(m) => Err(format!("step {}: {}", m.step, m.what)),
        }
    });
    assert_eq!(n, 210, "all 210 reference dumps are present");
}

#[test]
fn snapshot_round_trips_through_json() {
    let path = &common::fixtures("minigrid")[0];
    let snap = Snapshot::from_json(&std::fs::read_to_string(path).unwrap()).unwrap();
    let world = snap.to_world().unwrap();
    let again = Snapshot::from_world(&world, snap.env_id.clone(), snap.seed);
    let world2 = Snapshot::from_json(&again.to_json())
        .unwrap()
        .to_world()
        .unwrap();
    assert_eq!(world, world2);
    assert_eq!(again.grid, snap.grid);
    assert_eq!(again.grid_ascii, snap.grid_ascii);
    assert_eq!(
        again.initial_obs.unwrap().image,
        snap.initial_obs.unwrap().image
    );
}
