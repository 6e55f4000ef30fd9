//! `train --imitate --teacher`: a trained policy labels imitation's frames on a MiniGrid id
//! the bot cannot label; the run records its teacher, resumes exactly, and refuses a teacher
//! it cannot use with one line.

use crate::common::{assert_bad_input, gs, stderr};

use std::path::Path;

/// A small run on DoorKey-5x5 (16 hidden units, 4 × 32 frames an update).
fn args<'a>(dir: &'a Path, frames: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "train",
        "--level",
        "MiniGrid-DoorKey-5x5-v0",
        "--out",
        dir.to_str().unwrap(),
        "--frames",
        frames,
        "--procs",
        "4",
        "--frames-per-proc",
        "32",
        "--batch-size",
        "64",
        "--hidden",
        "16",
        "--save-interval",
        "1",
        "--eval-interval",
        "0",
        "--quiet",
    ];
    a.extend_from_slice(extra);
    a
}

/// A baseline student of an attention teacher: the cross-entropy on the teacher's actions
/// falls, the run state names the teacher by its absolute path, and a run stopped and
/// resumed (the teacher loaded again, its memories saved) ends with the weights of an
/// uninterrupted one.
#[test]
fn a_student_learns_its_teachers_actions_and_resumes_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let teacher = dir.path().join("teacher");
    let o = gs(&args(&teacher, "256", &["--model", "attention"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let name = teacher.join("model");
    let name = name.to_str().unwrap();
    let student = |out: &Path, frames: &str, more: &[&str]| {
        let mut extra = vec!["--model", "baseline", "--imitate", "--teacher", name];
        extra.extend_from_slice(more);
        let o = gs(&args(out, frames, &extra));
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    };
    let straight = dir.path().join("straight");
    student(&straight, "1536", &[]);
    let log = std::fs::read_to_string(straight.join("log.csv")).unwrap();
    let loss: Vec<f64> = log
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(7).unwrap().parse().unwrap())
        .collect();
    assert_eq!(loss.len(), 12, "{log}");
    assert!(
        loss[11] < 0.8 * loss[0],
        "the cross-entropy on the teacher's actions falls: {log}"
    );
    let newest = std::fs::read_dir(straight.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .max()
        .unwrap();
    let state = std::fs::read_to_string(newest.join("run_state.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&state).unwrap();
    assert_eq!(json["teachers"][0]["name"], name, "{}", json["teachers"]);
    assert!(json["envs"][0]["teacher_h"].as_array().unwrap().len() == 16);

    let split = dir.path().join("split");
    student(&split, "640", &[]);
    let o = gs(&args(&split, "1536", &["--model", "baseline", "--resume"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(split.join("model.safetensors")).unwrap(),
        std::fs::read(straight.join("model.safetensors")).unwrap(),
        "a resumed run of a teacher's student ends with other weights than an uninterrupted one"
    );
    // The teacher is the run's own on a resume.
    assert_bad_input(
        &gs(&args(
            &split,
            "2048",
            &[
                "--model",
                "baseline",
                "--resume",
                "--imitate",
                "--teacher",
                name,
            ],
        )),
        "--teacher",
    );
}

/// What a teacher cannot do is one line, exit 2, and no run directory.
#[test]
fn a_teacher_that_cannot_teach_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let teacher = dir.path().join("teacher");
    let o = gs(&args(&teacher, "128", &["--model", "baseline"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let name = teacher.join("model");
    let name = name.to_str().unwrap();
    let out = dir.path().join("out");
    let other = format!("MiniGrid-Unlock-v0={name}");
    let missing = dir.path().join("nope");
    let missing = missing.to_str().unwrap();
    for (extra, what) in [
        (vec!["--teacher", name], "--imitate"),
        (
            vec!["--imitate", "--teacher", other.as_str()],
            "MiniGrid-Unlock-v0",
        ),
        (vec!["--imitate", "--teacher", missing], "nope"),
        (
            vec!["--imitate", "--teacher", name, "--teacher", name],
            "both teach every level",
        ),
        (vec!["--imitate", "--teacher", "bot"], "bot"),
    ] {
        assert_bad_input(&gs(&args(&out, "128", &extra)), what);
        assert!(!out.exists(), "{extra:?} left {}", out.display());
    }
}
