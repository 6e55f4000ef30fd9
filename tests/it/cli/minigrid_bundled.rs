//! MiniGrid's bundled pair (`bundled:minigrid`, `bundled:minigrid-baseline`): the default of
//! `replay`, `eval` and `faithfulness` on MiniGrid's own ids, said on stderr; it reads every
//! MiniGrid id's missions; and it does what the study measured on validation seeds.

use crate::common::{csv_rows, gs, stderr};

#[test]
fn minigrid_ids_open_the_minigrid_pair_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.json");
    let o = gs(&[
        "replay",
        "--level",
        "MiniGrid-DoorKey-5x5-v0",
        "--seed",
        "1",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("opening bundled:minigrid"),
        "{}",
        stderr(&o)
    );
    let t: serde_json::Value = serde_json::from_slice(&std::fs::read(&trace).unwrap()).unwrap();
    assert!(t.to_string().contains("bundled:minigrid"));

    // The paper's level keeps the paper's model, with nothing said.
    let o = gs(&["replay", "--seed", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("minigrid"), "{}", stderr(&o));

    let report = dir.path().join("r");
    let o = gs(&[
        "eval",
        "--levels",
        "MiniGrid-Empty-Random-5x5-v0,MiniGrid-DoorKey-5x5-v0",
        "--first-seed",
        "1400",
        "--seeds",
        "1",
        "--episodes",
        "20",
        "--quiet",
        "--out",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("opening bundled:minigrid and bundled:minigrid-baseline"),
        "{}",
        stderr(&o)
    );
    let rows = csv_rows(&report.join("performance.csv"));
    let success = |ck: &str, level: &str| -> f64 {
        let r = rows
            .iter()
            .find(|r| r["checkpoint"] == ck && r["level"] == level)
            .unwrap_or_else(|| panic!("no row for {ck} on {level}"));
        r["success_mean"].parse().unwrap()
    };
    // The study's validation figures (seed 1400, 50 episodes, stage 10): 0.94 (attention) and
    // 0.88 (baseline) on Empty-Random, 0.92 and 0.98 on DoorKey-5x5; a model that lost them
    // would fall far below these bounds on the first 20 of those episodes.
    for (ck, level, at_least) in [
        ("bundled:minigrid", "MiniGrid-Empty-Random-5x5-v0", 0.7),
        ("bundled:minigrid", "MiniGrid-DoorKey-5x5-v0", 0.85),
        (
            "bundled:minigrid-baseline",
            "MiniGrid-Empty-Random-5x5-v0",
            0.75,
        ),
        ("bundled:minigrid-baseline", "MiniGrid-DoorKey-5x5-v0", 0.85),
    ] {
        let s = success(ck, level);
        assert!(s >= at_least, "{ck} on {level}: success {s}");
    }
}

#[test]
fn the_minigrid_model_reads_every_minigrid_id() {
    let o = gs(&["env", "list", "--checkpoint", "bundled:minigrid"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = crate::common::stdout(&o);
    let rows: Vec<&str> = out.lines().filter(|l| l.starts_with("MiniGrid-")).collect();
    assert_eq!(rows.len(), 76, "{out}");
    for r in rows {
        assert!(r.trim_end().ends_with("all 200"), "{r}");
    }
}

#[test]
fn faithfulness_on_a_minigrid_id_probes_the_minigrid_model() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f");
    let o = gs(&[
        "faithfulness",
        "--levels",
        "MiniGrid-GoToObject-6x6-N2-v0",
        "--first-seed",
        "1400",
        "--seeds",
        "1",
        "--episodes",
        "4",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("opening bundled:minigrid"),
        "{}",
        stderr(&o)
    );
    let report = std::fs::read_to_string(out.join("faithfulness.json")).unwrap();
    assert!(report.contains("bundled:minigrid"), "{report}");
}
