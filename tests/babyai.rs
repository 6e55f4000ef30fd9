//! Every BabyAI level against minigrid 3.2.0: numpy's stream, the calls level generation
//! makes, and 576 episode dumps (96 ids × 2 done modes × 3 seeds, BabyAIBot plus random
//! actions) regenerated from their id and seed and replayed.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::float_cmp,
    reason = "test helpers fail loudly"
)]

mod common;

use std::path::Path;

use groundscope::env::babyai::{self, registry::LEVELS};
use groundscope::env::rng::{Call, NumpyRng};
use groundscope::env::{Snapshot, verify_dump};
use serde_json::Value;

fn fixture_json(name: &str) -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/numpy")
        .join(name);
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn hex128(v: &Value) -> u128 {
    u128::from_str_radix(v.as_str().unwrap().trim_start_matches("0x"), 16).unwrap()
}

/// numpy's own streams: the seeded state and 300 mixed calls per seed, 64-bit seeds included.
#[test]
fn numpy_streams_match_numpy() {
    let streams = fixture_json("streams.json");
    for s in streams.as_array().unwrap() {
        let seed = s["seed"].as_u64().unwrap();
        let mut g = NumpyRng::new(seed);
        assert_eq!(
            g.state(),
            (hex128(&s["state"]), hex128(&s["inc"])),
            "seed {seed}"
        );
        for (k, c) in s["calls"].as_array().unwrap().iter().enumerate() {
            if let Some(u) = c.get("uniform") {
                let (a, b) = (u[0].as_f64().unwrap(), u[1].as_f64().unwrap());
                assert_eq!(
                    g.uniform(a, b),
                    c["value"].as_f64().unwrap(),
                    "seed {seed} call {k}"
                );
            } else {
                let r = &c["integers"];
                let (lo, hi) = (r[0].as_i64().unwrap(), r[1].as_i64().unwrap());
                assert_eq!(
                    g.integers(lo, hi),
                    c["value"].as_i64().unwrap(),
                    "seed {seed} call {k}"
                );
            }
        }
    }
}

/// Level generation calls numpy exactly as Python does, call by call (arguments and results).
#[test]
fn level_generation_draws_as_python_does() {
    let logs = fixture_json("calls.json");
    let mut checked = 0;
    for l in logs.as_array().unwrap() {
        let id = l["env_id"].as_str().unwrap();
        let seed = l["seed"].as_u64().unwrap();
        let spec = babyai::spec(id).unwrap();
        let (world, calls) = babyai::generate_logged(spec, seed, false).unwrap();
        let want = l["calls"].as_array().unwrap();
        for (k, (w, got)) in want.iter().zip(&calls).enumerate() {
            let w = w.as_array().unwrap();
            let same = match got {
                Call::Integers(lo, hi, v) => {
                    w[0] == "i"
                        && w[1].as_i64() == Some(*lo)
                        && w[2].as_i64() == Some(*hi)
                        && w[3].as_i64() == Some(*v)
                }
                Call::Uniform(lo, hi, v) => {
                    w[0] == "u"
                        && w[1].as_f64() == Some(*lo)
                        && w[2].as_f64() == Some(*hi)
                        && w[3].as_f64() == Some(*v)
                }
            };
            assert!(
                same,
                "{id} seed {seed}: call {k}: Python {w:?}, groundscope {got:?}"
            );
        }
        assert_eq!(calls.len(), want.len(), "{id} seed {seed}: number of calls");
        assert_eq!(
            world.mission,
            l["mission"].as_str().unwrap(),
            "{id} seed {seed}"
        );
        checked += 1;
    }
    assert_eq!(checked, 15);
}

/// `env verify` on one dump: its level regenerated from its id and seed, then its steps
/// replayed, every one of them.
fn regenerates_and_replays(path: &Path) -> Result<(), String> {
    let text = groundscope::files::read_text_maybe_gz(path).map_err(|e| e.to_string())?;
    let snap = Snapshot::from_json(&text).map_err(|e| e.to_string())?;
    match verify_dump(&snap).map_err(|e| e.to_string())? {
        Ok(steps) if steps == snap.steps.len() => Ok(()),
        Ok(steps) => Err(format!("replayed {steps} of {} steps", snap.steps.len())),
        Err(m) => Err(format!("step {}: {}", m.step, m.what)),
    }
}

/// Each dump's level regenerated from its id and seed, then its steps replayed.
#[test]
fn every_babyai_dump_regenerates_and_replays() {
    let n = common::for_each_fixture("babyai", regenerates_and_replays);
    assert_eq!(n, 576, "all 576 dumps are present");
}

/// Every registered id generates for many seeds, the same world twice.
#[test]
fn every_level_generates_deterministically() {
    for spec in LEVELS {
        for seed in 0..20 {
            let a = babyai::generate(spec, seed, false).unwrap();
            let b = babyai::generate(spec, seed, false).unwrap();
            assert_eq!(a, b, "{} seed {seed}", spec.id);
            assert!(!a.mission.is_empty());
        }
    }
}

/// The paper's level generated by minigrid itself (docs/world.md's class), regenerated and
/// replayed: 3 sizes × 2 done modes × 20 seeds.
#[test]
fn the_paper_level_is_minigrid_s_own() {
    let n = common::for_each_fixture("paper", regenerates_and_replays);
    assert_eq!(n, 120);
}

/// `env verify` names the first difference of a regenerated level (exit 1) and refuses
/// dumps it cannot regenerate (exit 2, one line); `--level` refuses unknown ids by name.
#[test]
fn env_verify_and_level_flags_refuse_what_they_cannot_check() {
    let dir = tempfile::tempdir().unwrap();
    let src = groundscope::files::read_text_maybe_gz(&common::fixtures("babyai")[0]).unwrap();
    let base: Value = serde_json::from_str(&src).unwrap();
    let write = |name: &str, v: &Value| {
        let p = dir.path().join(name);
        std::fs::write(&p, v.to_string()).unwrap();
        p.display().to_string()
    };
    // Another seed: a mismatch at step 0 naming the regenerated level.
    let mut v = base.clone();
    v["seed"] = (v["seed"].as_u64().unwrap() + 1).into();
    let o = common::gs(&["env", "verify", &write("seed.json", &v)]);
    assert_eq!(o.status.code(), Some(1));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("step 0: regenerated BabyAI-"), "{out}");
    // An unknown id, another minigrid version, a missing seed: bad input.
    let mut v = base.clone();
    v["env_id"] = "BabyAI-GoToObjMaz-v0".into();
    common::assert_bad_input(
        &common::gs(&["env", "verify", &write("id.json", &v)]),
        "BabyAI-GoToObjMaze-v0",
    );
    let mut v = base.clone();
    v["minigrid_version"] = "2.3.1".into();
    common::assert_bad_input(
        &common::gs(&["env", "verify", &write("ver.json", &v)]),
        "minigrid_version",
    );
    let mut v = base;
    v.as_object_mut().unwrap().remove("seed");
    common::assert_bad_input(
        &common::gs(&["env", "verify", &write("noseed.json", &v)]),
        "seed",
    );
    // --level: an unknown id names the closest; the paper's flags conflict with it.
    common::assert_bad_input(
        &common::gs(&["env", "show", "--level", "BabyAI-KeyCorridorS3R4-v0"]),
        "BabyAI-KeyCorridorS3R3-v0",
    );
    let o = common::gs(&["env", "show", "--level", "BabyAI-GoTo-v0", "--objects", "3"]);
    assert_eq!(o.status.code(), Some(2));
    let o = common::gs(&["env", "list"]);
    assert_eq!(o.status.code(), Some(0));
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().filter(|l| l.starts_with("BabyAI-")).count(), 96);
    assert!(
        out.contains("BabyAI-BossLevel-v0") && out.contains("22×22"),
        "{out}"
    );
}

/// `env show --snapshot` writes what `env verify` checks (docs/formats.md): BabyAI levels are
/// regenerated from the snapshot's id and seed, the paper's level replayed. The snapshot's
/// producer tag, `groundscope 0.1.0`, used to be refused as "another minigrid version".
#[test]
fn a_shown_snapshot_passes_env_verify() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    let shows: [&[&str]; 4] = [
        &["--level", "BabyAI-GoToLocal-v0", "--seed", "3"],
        &["--level", "BabyAI-KeyCorridorS3R3-v0", "--seed", "1"],
        &["--level", "BabyAI-BossLevel-v0", "--seed", "7"],
        &["--seed", "5"],
    ];
    for (i, flags) in shows.iter().enumerate() {
        let f = dir.path().join(format!("s{i}.json"));
        let mut args = vec!["env", "show", "--snapshot", f.to_str().unwrap()];
        args.extend_from_slice(flags);
        let o = common::gs(&args);
        assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
        files.push(f.display().to_string());
    }
    let mut args = vec!["env", "verify"];
    args.extend(files.iter().map(String::as_str));
    let o = common::gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    assert!(
        common::stdout(&o).contains("4 passed, 0 failed"),
        "{}",
        common::stdout(&o)
    );
}

/// A mission word outside the agent's vocabulary is one line naming the word and the level
/// (the model given: without `--checkpoint`, `replay` opens `bundled:babyai` there).
#[test]
fn an_unknown_mission_word_names_the_level() {
    common::assert_bad_input(
        &common::gs(&[
            "replay",
            "--checkpoint",
            "bundled:attention",
            "--level",
            "BabyAI-OpenRedDoor-v0",
            "--seed",
            "0",
        ]),
        "\"open\" in mission \"open the red door\" of level BabyAI-OpenRedDoor-v0",
    );
    let o = common::gs(&["replay", "--level", "BabyAI-GoToObjMaze-v0", "--seed", "1"]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
}

/// A multi-room level with doors runs through the recorders and the renderer: the bundled
/// agent on GoToObjMazeS4 to Rerun and MCAP, and BossLevel's 22 × 22 grid to a PNG.
#[test]
fn multi_room_levels_record_and_render() {
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("maze.rrd");
    let mcap = dir.path().join("maze.mcap");
    let trace = dir.path().join("maze.json");
    let o = common::gs(&[
        "replay",
        "--level",
        "BabyAI-GoToObjMazeS4-v0",
        "--seed",
        "2",
        "--save",
        rrd.to_str().unwrap(),
        "--mcap",
        mcap.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    assert!(std::fs::metadata(&rrd).unwrap().len() > 10_000);
    assert!(std::fs::metadata(&mcap).unwrap().len() > 1_000);
    let t: Value = serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    assert!(
        t.to_string().contains("BabyAI-GoToObjMazeS4-v0"),
        "the trace names its level"
    );
    let png = dir.path().join("boss.png");
    let o = common::gs(&[
        "env",
        "show",
        "--level",
        "BabyAI-BossLevel-v0",
        "--seed",
        "1",
        "--tile",
        "8",
        "--png",
        png.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (22 * 8, 22 * 8));
}

/// minigrid 3.2.0 never finishes resetting BabyAI-SynthS5R2-v0 on seed 1741 (`place_agent`
/// redraws forever: every free cell of the room faces an object on all four sides); groundscope
/// stops there with one line naming the level and seed, exit 2, instead of hanging.
#[test]
fn a_seed_minigrid_loops_on_forever_is_an_error_not_a_hang() {
    let spec = babyai::spec("BabyAI-SynthS5R2-v0").unwrap();
    let err = babyai::generate(spec, 1741, false).unwrap_err().to_string();
    assert!(
        err.contains("BabyAI-SynthS5R2-v0 seed 1741") && err.contains("loops forever"),
        "{err}"
    );
    // Its neighbours generate as before.
    assert!(babyai::generate(spec, 1740, false).is_ok());
    let o = common::gs(&[
        "env",
        "show",
        "--level",
        "BabyAI-SynthS5R2-v0",
        "--seed",
        "1741",
    ]);
    common::assert_bad_input(&o, "seed 1741");
}
