//! `train --levels`: several registered levels in one run, tracked level by level, resumed
//! exactly; `--imitate-policy-share`, imitation on the policy's own trajectories; and
//! `--threads`, the whole update on several threads, deterministic for a count.

use crate::common::{assert_bad_input, gs, stderr};

use std::path::Path;

const MIX: &str = "BabyAI-GoToLocalS6N3-v0:2,BabyAI-OpenDoorLoc-v0";

/// A small imitation run on [`MIX`].
fn mix_args<'a>(dir: &'a Path, frames: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "train",
        "--imitate",
        "--levels",
        MIX,
        "--out",
        dir.to_str().unwrap(),
        "--frames",
        frames,
        "--procs",
        "8",
        "--frames-per-proc",
        "16",
        "--batch-size",
        "64",
        "--hidden",
        "16",
        "--save-interval",
        "1",
        "--eval-interval",
        "2",
        "--eval-episodes",
        "3",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    args
}

/// Rows of a CSV file, header dropped, fields split on commas.
fn rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect()
}

/// Episodes come from every level of the mix; each tracked evaluation writes a row per level
/// and one of their mean; a run stopped and resumed (its levels kept without the flag) ends
/// with the weights of an uninterrupted one; another list on resume is refused.
#[test]
fn a_run_on_several_levels_tracks_each_and_resumes_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let straight = dir.path().join("straight");
    let o = gs(&mix_args(&straight, "1024", &[]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let state =
        std::fs::read_to_string(straight.join("checkpoints/update-00000008/run_state.json"))
            .unwrap();
    assert!(state.contains("\"go to "), "a GoTo mission among the envs");
    assert!(
        state.contains("\"open the "),
        "an OpenDoorLoc mission among the envs"
    );
    let evals = rows(&straight.join("eval_log.csv"));
    assert_eq!(
        evals.len(),
        4 * 3,
        "four evaluations of two levels and their mean"
    );
    let levels: Vec<&str> = evals[..3].iter().map(|r| r[13].as_str()).collect();
    assert_eq!(
        levels,
        [
            "BabyAI-GoToLocalS6N3-v0",
            "BabyAI-OpenDoorLoc-v0",
            "mean of levels"
        ]
    );
    for block in evals.chunks(3) {
        let s = |r: &Vec<String>| r[3].parse::<f64>().unwrap();
        assert!((s(&block[2]) - f64::midpoint(s(&block[0]), s(&block[1]))).abs() < 1e-3);
        assert_eq!(
            block[2][2], "6",
            "the mean row counts both levels' episodes"
        );
    }

    let whole = dir.path().join("whole");
    let o = gs(&mix_args(&whole, "384", &[]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut resume = mix_args(&whole, "1024", &["--resume"]);
    resume.retain(|a| *a != "--imitate" && *a != MIX && *a != "--levels");
    let o = gs(&resume);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(whole.join("model.safetensors")).unwrap(),
        std::fs::read(straight.join("model.safetensors")).unwrap(),
        "a resumed run on several levels ends with other weights than an uninterrupted one"
    );
    // The same evaluations, wall times aside.
    let timeless = |rs: Vec<Vec<String>>| {
        rs.into_iter()
            .map(|mut r| {
                r.remove(12);
                r
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(
        timeless(rows(&whole.join("eval_log.csv"))),
        timeless(evals.clone())
    );
    let mut other = mix_args(&whole, "2048", &["--resume"]);
    other[3] = "BabyAI-GoToLocalS6N3-v0";
    assert_bad_input(&gs(&other), "--levels");
    // The checkpoint names the first level: the one `view` and `eval` open by default.
    let meta = std::fs::read_to_string(whole.join("model.json")).unwrap();
    assert!(meta.contains("BabyAI-GoToLocalS6N3-v0"), "{meta}");
}

/// Taking the policy's own actions (an untrained one) makes episodes fail where the bot alone
/// never does, while the bot's advice still labels every step.
#[test]
fn the_policy_share_takes_the_policys_own_actions() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("own");
    let o = gs(&mix_args(&run, "1024", &["--imitate-policy-share", "1"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let log = rows(&run.join("log.csv"));
    let success: Vec<f64> = log
        .iter()
        .filter(|r| r[3] != "0")
        .map(|r| r[4].parse().unwrap())
        .collect();
    assert!(
        success.iter().any(|&s| s < 1.0),
        "the untrained policy's own actions fail some episodes: {success:?}"
    );
    assert!(log.iter().all(|r| r[7].parse::<f64>().unwrap() > 0.0));
    let settings =
        std::fs::read_to_string(run.join("checkpoints/update-00000008/resume.json")).unwrap();
    assert!(
        settings.contains("\"imitate_policy_share\":1.0"),
        "{settings}"
    );
}

/// Bad lists and shares are refused in one line naming the flag and the item, leaving no run
/// directory behind.
#[test]
fn bad_levels_and_shares_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    for (list, says) in [
        ("BabyAI-Nope-v0", "BabyAI-Nope-v0"),
        ("BabyAI-GoToLocal-v0:0", "positive"),
        ("BabyAI-GoToLocal-v0:many", "many"),
        ("BabyAI-GoToLocal-v0,BabyAI-GoToLocal-v0", "twice"),
        (",", "no level"),
    ] {
        let mut args = mix_args(&out, "64", &[]);
        args[3] = list;
        assert_bad_input(&gs(&args), says);
        assert!(!out.exists(), "{list}");
    }
    let mut args = mix_args(&out, "64", &["--size", "6"]);
    args.retain(|a| *a != "--imitate");
    assert_eq!(gs(&args).status.code(), Some(2));
    for share in ["1.5", "-0.1"] {
        assert_bad_input(
            &gs(&mix_args(&out, "64", &["--imitate-policy-share", share])),
            "--imitate-policy-share",
        );
    }
    let mut args = mix_args(&out, "64", &["--imitate-policy-share", "0.5"]);
    args.retain(|a| *a != "--imitate");
    assert_bad_input(&gs(&args), "--imitate");
    assert!(!out.exists());
}

/// Two runs with `--threads 2` (the rollout's environments and forward passes and the update
/// split over two threads) end with the same bytes; the flag's old name still works, and the
/// count is kept on resume.
#[test]
fn a_run_on_two_threads_is_the_same_every_time() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let o = gs(&mix_args(&a, "512", &["--threads", "2"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = gs(&mix_args(&b, "512", &["--update-threads", "2"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for f in ["model.safetensors", "log.csv"] {
        let (x, y) = (
            std::fs::read_to_string(a.join(f)).unwrap_or_default(),
            std::fs::read_to_string(b.join(f)).unwrap_or_default(),
        );
        if f == "log.csv" {
            // Columns 3 (frames/s) and 12 (seconds) are timings.
            let strip = |t: &str| -> Vec<String> {
                t.lines()
                    .map(|l| {
                        l.split(',')
                            .enumerate()
                            .filter(|(k, _)| *k != 2 && *k != 11)
                            .map(|(_, v)| v)
                            .collect::<Vec<_>>()
                            .join(",")
                    })
                    .collect()
            };
            assert_eq!(strip(&x), strip(&y));
        } else {
            assert_eq!(
                std::fs::read(a.join(f)).unwrap(),
                std::fs::read(b.join(f)).unwrap(),
                "two runs on two threads differ"
            );
        }
    }
    let settings =
        std::fs::read_to_string(a.join("checkpoints/update-00000004/resume.json")).unwrap();
    assert!(settings.contains("\"threads\":2"), "{settings}");
    assert_bad_input(
        &gs(&mix_args(&a, "1024", &["--resume", "--threads", "1"])),
        "--threads",
    );
}
