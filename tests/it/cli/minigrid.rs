//! MiniGrid's own environments in every command: `init`, `train`, `replay` (`.rrd`, MCAP),
//! `eval --levels`, `faithfulness --levels`, `bench env`, `env list`, and the refusals (a WFC
//! id, `--done`, `--checkpoint bot`, a model that lacks MiniGrid's words).

use crate::common::{assert_bad_input, gs, stderr, stdout};

fn ok(args: &[&str]) -> String {
    let o = gs(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

#[test]
fn minigrid_ids_run_in_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let path = |f: &str| dir.path().join(f).to_string_lossy().into_owned();
    let model = path("m");
    ok(&[
        "init",
        "--model",
        "attention",
        "--seed",
        "1",
        "--out",
        &model,
        "--level",
        "MiniGrid-DoorKey-5x5-v0",
    ]);
    // A moving obstacle's episode and a class with its arguments, recorded in both formats.
    for level in [
        "MiniGrid-Dynamic-Obstacles-5x5-v0",
        "MultiRoomEnv(minNumRooms=2, maxNumRooms=2, maxRoomSize=5)",
    ] {
        let (rrd, mcap) = (path("a.rrd"), path("a.mcap"));
        ok(&[
            "replay",
            "--checkpoint",
            &model,
            "--level",
            level,
            "--seed",
            "1",
            "--save",
            &rrd,
            "--mcap",
            &mcap,
        ]);
        assert!(std::fs::metadata(&rrd).unwrap().len() > 1000, "{level}");
        assert!(std::fs::metadata(&mcap).unwrap().len() > 1000, "{level}");
    }
    let ev = path("ev");
    ok(&[
        "eval",
        "--checkpoint",
        &model,
        "--levels",
        "MiniGrid-DoorKey-5x5-v0,MiniGrid-Fetch-5x5-N2-v0",
        "--seeds",
        "1",
        "--episodes",
        "3",
        "--out",
        &ev,
        "--quiet",
    ]);
    let csv = std::fs::read_to_string(dir.path().join("ev/episodes.csv")).unwrap();
    assert_eq!(
        csv.lines()
            .filter(|l| l.contains(",MiniGrid-Fetch-5x5-N2-v0,"))
            .count(),
        3
    );
    let md = std::fs::read_to_string(dir.path().join("ev/report.md")).unwrap();
    assert!(
        md.lines()
            .any(|l| l.contains("MiniGrid-DoorKey-5x5-v0")
                && l.ends_with("none | none | none | none |")),
        "the expert columns say none: {md}"
    );
    ok(&[
        "faithfulness",
        "--checkpoint",
        &model,
        "--levels",
        "MiniGrid-GoToObject-6x6-N2-v0",
        "--episodes",
        "2",
        "--out",
        &path("fa"),
    ]);
    assert!(dir.path().join("fa/faithfulness.json").exists());
    ok(&[
        "train",
        "--model",
        "baseline",
        "--out",
        &path("run"),
        "--levels",
        "MiniGrid-Empty-5x5-v0,MiniGrid-Dynamic-Obstacles-5x5-v0",
        "--frames",
        "256",
        "--procs",
        "2",
        "--frames-per-proc",
        "64",
        "--hidden",
        "8",
        "--quiet",
    ]);
    let bench = ok(&[
        "bench",
        "env",
        "--level",
        "MiniGrid-Dynamic-Obstacles-16x16-v0",
        "--steps",
        "2000",
        "--resets",
        "50",
    ]);
    assert!(bench.contains("\"steps_per_sec\""), "{bench}");
}

#[test]
fn env_list_names_both_families_and_their_actions() {
    let out = ok(&["env", "list"]);
    let row = |id: &str| {
        out.lines()
            .find(|l| l.starts_with(&format!("{id} ")))
            .unwrap_or_else(|| panic!("no row for {id}"))
            .to_owned()
    };
    let dynamic = row("MiniGrid-Dynamic-Obstacles-8x8-v0");
    let dynamic: Vec<&str> = dynamic.split_whitespace().collect();
    assert_eq!(dynamic[1..3], ["MiniGrid", "Dynamic-Obstacles"]);
    assert_eq!(dynamic[6], "3", "three actions");
    assert!(row("MiniGrid-LavaCrossingS9N1-v0").contains("avoid the lava"));
    assert!(row("BabyAI-GoToLocal-v0").starts_with("BabyAI-GoToLocal-v0 "));
    assert_eq!(
        out.lines().filter(|l| l.starts_with("MiniGrid-")).count(),
        76
    );
    assert!(
        out.contains("172 levels of minigrid 3.2.0: 96 BabyAI, 76 MiniGrid"),
        "{out}"
    );
}

#[test]
fn refused_minigrid_requests_say_why() {
    assert_bad_input(
        &gs(&["env", "show", "--level", "MiniGrid-WFC-MazeSimple-v0"]),
        "minigrid itself cannot build it",
    );
    assert_bad_input(
        &gs(&[
            "env",
            "show",
            "--level",
            "MiniGrid-DoorKey-5x5-v0",
            "--done",
        ]),
        "no done-action mode",
    );
    assert_bad_input(
        &gs(&["env", "show", "--level", "MiniGrid-DoorKey-5x5-v1"]),
        "MiniGrid-DoorKey-5x5-v0",
    );
    assert_bad_input(
        &gs(&[
            "env",
            "show",
            "--level",
            "MultiRoomEnv(minNumRooms=2, rooms=3)",
        ]),
        "rooms",
    );
    assert_bad_input(
        &gs(&[
            "replay",
            "--checkpoint",
            "bot",
            "--level",
            "MiniGrid-Fetch-5x5-N2-v0",
            "--seed",
            "1",
        ]),
        "BabyAI's bot plans BabyAI instructions only",
    );
    // A model without MiniGrid's words: the refusal names the bundled one that has them and
    // how to make one.
    let o = gs(&[
        "replay",
        "--checkpoint",
        "bundled:babyai",
        "--level",
        "MiniGrid-DoorKey-5x5-v0",
        "--seed",
        "1",
    ]);
    assert_bad_input(&o, "init --level ID");
    assert_bad_input(&o, "bundled:minigrid");
}
