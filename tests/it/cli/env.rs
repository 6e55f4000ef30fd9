//! The command line's `env` commands and its argument errors: exit codes, one-line errors,
//! counts and pictures. (Split from `cli::commands`.)

use crate::common::{self, assert_bad_input, gs, stderr, stdout};

#[test]
fn env_verify_passes_the_reference_dumps_and_counts() {
    let files: Vec<String> = common::fixtures("minigrid")
        .iter()
        .take(20)
        .map(|p| p.display().to_string())
        .collect();
    let args: Vec<&str> = ["env", "verify"]
        .into_iter()
        .chain(files.iter().map(String::as_str))
        .collect();
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).trim_end().ends_with("20 passed, 0 failed"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn env_verify_reports_a_mismatch_with_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let src = &common::fixtures("minigrid")[0];
    let mut dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(src).unwrap()).unwrap();
    let reward = dump["steps"].as_array().unwrap().len() - 1;
    dump["steps"][reward]["truncated"] =
        serde_json::json!(!dump["steps"][reward]["truncated"].as_bool().unwrap());
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, dump.to_string()).unwrap();
    let o = gs(&[
        "env",
        "verify",
        src.to_str().unwrap(),
        bad.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let out = stdout(&o);
    assert!(
        out.contains("bad.json: step") && out.contains("truncated"),
        "{out}"
    );
    assert!(out.trim_end().ends_with("1 passed, 1 failed"), "{out}");
}

#[test]
fn env_verify_rejects_bad_dumps_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let src = std::fs::read_to_string(&common::fixtures("minigrid")[0]).unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    };
    assert_bad_input(
        &gs(&["env", "verify", &write("trunc.json", &src[..src.len() / 2])]),
        "trunc.json",
    );
    let mut v: serde_json::Value = serde_json::from_str(&src).unwrap();
    v["surprise"] = serde_json::json!(1);
    assert_bad_input(
        &gs(&["env", "verify", &write("unknown.json", &v.to_string())]),
        "surprise",
    );
    let mut v: serde_json::Value = serde_json::from_str(&src).unwrap();
    v["grid"][2][3] = serde_json::json!([42, 0, 0]);
    assert_bad_input(
        &gs(&["env", "verify", &write("range.json", &v.to_string())]),
        "grid[2][3][0]",
    );
    let mut v: serde_json::Value = serde_json::from_str(&src).unwrap();
    v["agent_dir"] = serde_json::json!(7);
    assert_bad_input(
        &gs(&["env", "verify", &write("dir.json", &v.to_string())]),
        "agent_dir",
    );
    let mut v: serde_json::Value = serde_json::from_str(&src).unwrap();
    v["mission"] = serde_json::json!("go to the pink key");
    assert_bad_input(
        &gs(&["env", "verify", &write("mission.json", &v.to_string())]),
        "mission",
    );
    assert_bad_input(
        &gs(&["env", "verify", "/nonexistent/dump.json"]),
        "/nonexistent/dump.json",
    );
}

/// A missing required argument is named in the one-line error (clap puts the names on the
/// lines after "the following required arguments were not provided:", which the one-line
/// error used to cut off).
#[test]
fn a_missing_required_argument_is_named() {
    for (args, name) in [
        (&["env", "verify"][..], "<FILE>"),
        (&["eval", "--seeds", "1"][..], "--out <DIR>"),
        (&["train"][..], "--out <DIR>"),
        (&["faithfulness"][..], "--out <DIR>"),
        (&["curve", "--out", "c.png"][..], "<LOG.csv>"),
    ] {
        let o = gs(args);
        assert_bad_input(
            &o,
            &format!("the following required arguments were not provided: {name}"),
        );
        assert!(
            stderr(&o).trim_end().ends_with("(see --help)"),
            "{}",
            stderr(&o)
        );
    }
}

#[test]
fn env_show_prints_the_level_and_writes_pictures() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("w.png");
    let snap = dir.path().join("w.json");
    let o = gs(&[
        "env",
        "show",
        "--seed",
        "4",
        "--png",
        png.to_str().unwrap(),
        "--snapshot",
        snap.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains("mission: ") && out.contains("WGWGWGWGWGWGWGWG"),
        "{out}"
    );
    // The grid's letters are explained under it.
    assert!(out.contains("legend: ") && out.contains("A ball"), "{out}");
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (256, 256));
    let again = gs(&["env", "show", "--seed", "4"]);
    assert_eq!(
        stdout(&again),
        out.lines()
            .filter(|l| !l.starts_with("wrote"))
            .map(|l| format!("{l}\n"))
            .collect::<String>()
    );
    // The snapshot replays in the verifier (no steps, so it passes trivially but must load).
    let o = gs(&["env", "verify", snap.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // `--room-size` is the room everywhere; the old `--size` is kept as a hidden alias.
    assert_bad_input(&gs(&["env", "show", "--room-size", "4"]), "room_size");
    assert_bad_input(&gs(&["env", "show", "--size", "4"]), "room_size");
    let shown = |flag: &str| stdout(&gs(&["env", "show", flag, "10", "--objects", "3"]));
    assert!(shown("--room-size").starts_with("level: S10N3"));
    assert_eq!(shown("--room-size"), shown("--size"));
    assert_bad_input(
        &gs(&["env", "show", "--size", "5", "--objects", "9"]),
        "n_objects",
    );
    assert_bad_input(&gs(&["env", "show", "--tasks", "dance"]), "tasks");
    let missing = dir.path().join("no/such/dir/w.png");
    assert_bad_input(
        &gs(&["env", "show", "--png", missing.to_str().unwrap()]),
        "w.png",
    );
    assert!(!missing.exists());
}
