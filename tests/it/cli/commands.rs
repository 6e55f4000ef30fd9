//! The command line: exit codes, one-line errors, no half-written files.

use crate::common::{assert_bad_input, gs, stderr, stdout};
use groundscope::metrics::grounding::WordKind;

#[test]
fn init_and_replay_write_checkpoints_and_traces() {
    let dir = tempfile::tempdir().unwrap();
    let name = dir.path().join("u");
    let o = gs(&[
        "init",
        "--model",
        "attention",
        "--seed",
        "3",
        "--out",
        name.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let trace = dir.path().join("t.json");
    let o = gs(&[
        "replay",
        "--checkpoint",
        name.to_str().unwrap(),
        "--seed",
        "2",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    for key in ["checkpoint", "level", "seed", "mission", "tokens", "steps"] {
        assert!(v.get(key).is_some(), "trace lacks {key}");
    }
    let step = &v["steps"][0];
    for key in [
        "t",
        "agent_pos",
        "agent_dir",
        "obs",
        "action",
        "probs",
        "value",
        "reward",
        "terminated",
        "truncated",
        "attention",
    ] {
        assert!(step.get(key).is_some(), "step lacks {key}");
    }
    let words = step["attention"]["words"].as_array().unwrap();
    assert_eq!(words.len(), v["tokens"].as_array().unwrap().len());
    assert_eq!(words[0]["map"].as_array().unwrap().len(), 7);
    assert_eq!(
        step["attention"]["combined"][6].as_array().unwrap().len(),
        7
    );
    assert_bad_input(
        &gs(&[
            "replay",
            "--checkpoint",
            name.to_str().unwrap(),
            "--mission",
            "go to the pink key",
        ]),
        "\"pink\"",
    );
    assert_bad_input(
        &gs(&["replay", "--checkpoint", "/nonexistent/ckpt"]),
        "/nonexistent/ckpt.json",
    );
    assert_bad_input(
        &gs(&[
            "init",
            "--model",
            "transformer",
            "--out",
            name.to_str().unwrap(),
        ]),
        "transformer",
    );
    let t2 = dir.path().join("t2.json");
    let o = gs(&[
        "replay",
        "--checkpoint",
        name.to_str().unwrap(),
        "--seed",
        "2",
        "--trace",
        t2.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(
        std::fs::read(&trace).unwrap(),
        std::fs::read(&t2).unwrap(),
        "same seed, same trace"
    );
}

#[test]
fn eval_writes_a_complete_report_and_gates_on_thresholds() {
    let dir = tempfile::tempdir().unwrap();
    let name = dir.path().join("u");
    assert_eq!(
        gs(&[
            "init",
            "--model",
            "attention",
            "--seed",
            "2",
            "--out",
            name.to_str().unwrap()
        ])
        .status
        .code(),
        Some(0)
    );
    let out = dir.path().join("report");
    let ckpt = name.to_str().unwrap();
    let args = [
        "eval",
        "--checkpoint",
        ckpt,
        "--checkpoint",
        "bundled:baseline",
        "--sizes",
        "6,8",
        "--objects",
        "2,3",
        "--seeds",
        "2",
        "--episodes",
        "3",
        "--quiet",
        "--out",
    ];
    let mut a: Vec<&str> = args.to_vec();
    a.push(out.to_str().unwrap());
    let o = gs(&a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for f in [
        "report.json",
        "report.md",
        "performance.csv",
        "accuracy.csv",
        "around.csv",
        "words.csv",
        "failures.json",
        "fig6_reward.png",
        "fig6_success.png",
        "fig7_object_accuracy.png",
        "fig8_color_accuracy.png",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let report: groundscope::metrics::report::Report =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report.schema_version, 1);
    assert_eq!(report.cells.len(), 8);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let cell = &v["cells"][0];
    for key in ["checkpoint", "size", "objects", "episodes"] {
        assert!(cell.get(key).is_some(), "cell lacks {key}");
    }
    for key in ["reward", "success", "length"] {
        assert!(
            cell[key].get("mean").is_some() && cell[key].get("std").is_some(),
            "{key}"
        );
    }
    for word in ["object", "color"] {
        for acc in ["acc", "acc_ng", "acc_bs", "acc_cmb"] {
            assert!(
                cell["accuracy"][word][acc].get("mean").is_some(),
                "accuracy.{word}.{acc}"
            );
        }
    }
    assert!(
        v["cells"][7]["accuracy"].is_null(),
        "no accuracies for the baseline"
    );
    // The offsets around the objects: `on` is acc and `forward` acc_bs, cell by cell; 4
    // attention cells × 3 word kinds × 9 offsets in around.csv, none for the baseline.
    for c in report.cells.iter().filter_map(|c| c.accuracy.as_ref()) {
        for g in [&c.object, &c.color, &c.combined] {
            assert_eq!((g.around[4], g.around[1]), (g.acc, g.acc_bs), "{g:?}");
        }
    }
    let around = std::fs::read_to_string(out.join("around.csv")).unwrap();
    assert_eq!(around.lines().count(), 1 + 4 * 3 * 9, "{around}");
    assert!(!around.contains("bundled:baseline"));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("| word | forward-left | forward | forward-right |"),
        "{md}"
    );
    // Word by word: each attention cell lists the words its missions named, and a word's
    // episodes add up to its kind's (every mission names one object word, at most one colour).
    for c in report.cells.iter().filter(|c| c.accuracy.is_some()) {
        let words = &c.accuracy.as_ref().unwrap().words;
        let count = |kind: WordKind| -> u64 {
            words
                .iter()
                .filter(|w| w.kind == kind)
                .map(|w| w.episodes)
                .sum()
        };
        assert_eq!(count(WordKind::Object), c.episodes, "{words:?}");
        assert!(count(WordKind::Color) <= c.episodes);
        assert!(
            words
                .iter()
                .all(|w| w.episodes > 0 && w.kind != WordKind::Combined)
        );
    }
    let words_csv = std::fs::read_to_string(out.join("words.csv")).unwrap();
    let n_words: usize = report
        .cells
        .iter()
        .filter_map(|c| c.accuracy.as_ref())
        .map(|a| a.words.len())
        .sum();
    assert_eq!(words_csv.lines().count(), 1 + n_words, "{words_csv}");
    assert!(
        md.contains("| checkpoint | size | objects | key | ball | box | red |"),
        "{md}"
    );
    // Failure classes: one per failed episode; baselines cannot be judged on grounding.
    for c in &report.cells {
        let failed = c.episodes - (c.success.mean.unwrap() * c.episodes as f64).round() as u64;
        assert_eq!(c.failure_classes.values().sum::<u64>(), failed, "{c:?}");
    }
    assert!(v["cells"][0]["failure_classes"].get("grounding").is_some());
    assert!(v["cells"][7]["failure_classes"].get("grounding").is_none());
    assert!(
        v["cells"][7]["failure_classes"]
            .get("turning_in_place")
            .is_some()
    );
    // Same inputs, same numbers (apart from the wall time).
    let out2 = dir.path().join("again");
    a.pop();
    a.push(out2.to_str().unwrap());
    assert_eq!(gs(&a).status.code(), Some(0));
    let mut r2: groundscope::metrics::report::Report =
        serde_json::from_str(&std::fs::read_to_string(out2.join("report.json")).unwrap()).unwrap();
    r2.elapsed_secs = report.elapsed_secs;
    assert_eq!(r2, report);
    // Every listed failure replays to the same outcome.
    let failures: Vec<groundscope::metrics::report::Failure> =
        serde_json::from_str(&std::fs::read_to_string(out.join("failures.json")).unwrap()).unwrap();
    for f in failures.iter().filter(|f| f.kind == "failed") {
        assert!(f.class.is_some() && f.counterfactual.is_some(), "{f:?}");
    }
    if let Some(f) = failures.iter().find(|f| f.kind == "failed") {
        let o = gs(&[
            "replay",
            "--checkpoint",
            &f.checkpoint,
            "--size",
            &f.size.to_string(),
            "--objects",
            &f.objects.to_string(),
            "--seed",
            &f.seed.to_string(),
        ]);
        assert!(
            stdout(&o).contains(&format!("failure in {} steps", f.length)),
            "{}",
            stdout(&o)
        );
    }
    // Thresholds: an impossible one fails with exit 1 and names the metric.
    a.pop();
    let out3 = dir.path().join("gate");
    a.push(out3.to_str().unwrap());
    a.extend(["--min-success", "1.0"]);
    let o = gs(&a);
    assert_eq!(o.status.code(), Some(1));
    assert!(stdout(&o).contains("--min-success"), "{}", stdout(&o));
    // Bad input: exit 2, no report.
    let bad = dir.path().join("bad");
    let b = bad.to_str().unwrap();
    assert_bad_input(&gs(&["eval", "--out", b, "--alpha", "1.5"]), "--alpha");
    assert_bad_input(
        &gs(&["eval", "--out", b, "--min-success", "1e300"]),
        "--min-success 1e300 is outside",
    );
    assert_bad_input(&gs(&["eval", "--out", b, "--episodes", "0"]), "empty");
    assert_bad_input(&gs(&["eval", "--out", b, "--sizes", "4"]), "room_size");
    assert_bad_input(
        &gs(&["eval", "--out", b, "--sizes", "6", "--objects", "40"]),
        "n_objects",
    );
    assert_bad_input(
        &gs(&["eval", "--out", b, "--checkpoint", "/nonexistent/x"]),
        "/nonexistent/x.json",
    );
    assert_bad_input(
        &gs(&["eval", "--out", b, "--first-seed", "2146", "--seeds", "2"]),
        "--first-seed 2146",
    );
    assert!(!bad.exists(), "no partial report");
}

/// `--first-seed S` plays evaluation seeds S.. (level seeds S·10⁶ + e), and says so.
#[test]
fn eval_first_seed_moves_the_levels() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("held-out");
    let o = gs(&[
        "eval",
        "--checkpoint",
        "bundled:attention",
        "--sizes",
        "8",
        "--objects",
        "4",
        "--seeds",
        "2",
        "--first-seed",
        "7",
        "--episodes",
        "3",
        "--top-k",
        "6",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["first_seed"], 7);
    assert_eq!(report["cells"][0]["episodes"], 6);
    let listed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("failures.json")).unwrap()).unwrap();
    let seeds: Vec<u64> = listed
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["seed"].as_u64().unwrap())
        .collect();
    assert!(!seeds.is_empty(), "the low-acc_cmb list names episodes");
    for s in seeds {
        assert!(
            (7_000_000..7_000_003).contains(&s) || (8_000_000..8_000_003).contains(&s),
            "level seed {s} is not one of evaluation seeds 7 and 8"
        );
    }
    assert!(
        std::fs::read_to_string(out.join("report.md"))
            .unwrap()
            .contains("2 seeds (from 7)")
    );
}

#[test]
fn replay_records_rerun_and_mcap_and_refuses_bad_destinations() {
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("two.rrd");
    let mcap = dir.path().join("two.mcap");
    let o = gs(&[
        "replay",
        "--seed",
        "3",
        "--episodes",
        "2",
        "--save",
        rrd.to_str().unwrap(),
        "--mcap",
        mcap.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("seed 3") && out.contains("seed 4"), "{out}");
    assert!(out.contains("KB/step") && out.contains("steps/s"), "{out}");
    assert!(std::fs::metadata(&rrd).unwrap().len() > 1000);
    assert!(std::fs::metadata(&mcap).unwrap().len() > 1000);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        let mode = std::fs::metadata(&rrd).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o644, "recordings are readable like any file");
    }

    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    let missing = dir.path().join("no/dir/x.rrd");
    for (args, what) in [
        (vec!["replay", "--save", "x.txt"], ".rrd"),
        (vec!["replay", "--mcap", "x.rrd"], ".mcap"),
        (
            vec!["replay", "--save", missing.to_str().unwrap()],
            "no/dir/x.rrd",
        ),
        (vec!["replay", "--mission", "go to the pink key"], "pink"),
        (vec!["replay", "--connect", url.as_str()], "no Rerun viewer"),
        (vec!["replay", "--episodes", "0"], "--episodes"),
        (
            vec!["replay", "--episodes", "2", "--trace", "t.json"],
            "--trace",
        ),
        (
            vec!["replay", "--checkpoint", "nope/missing"],
            "nope/missing",
        ),
        (vec!["replay", "--size", "70"], "70"),
    ] {
        let o = gs(&args);
        assert_bad_input(&o, what);
    }
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 2, "only the two recordings: {left:?}");
}

#[test]
fn eval_exports_each_listed_failure_as_a_recording() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    // An untrained model fails every episode, and its maps miss: its episodes are listed both
    // as failures and for their low acc_cmb, and each is recorded once.
    let fresh = dir.path().join("fresh");
    let o = gs(&["init", "--out", fresh.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = gs(&[
        "eval",
        "--checkpoint",
        "bundled:attention",
        "--checkpoint",
        fresh.to_str().unwrap(),
        "--sizes",
        "8",
        "--objects",
        "4",
        "--seeds",
        "1",
        "--episodes",
        "10",
        "--top-k",
        "12",
        "--export-failures",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let failures: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(out.join("failures.json")).unwrap()).unwrap();
    let mut recorded: Vec<String> = std::fs::read_dir(out.join("failures"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    recorded.sort();
    // One recording per episode, under the first kind it is listed for.
    let mut seen = std::collections::BTreeSet::new();
    let (mut failed, mut successes) = (0, 0);
    for f in &failures {
        if !seen.insert((f["checkpoint"].to_string(), f["seed"].to_string())) {
            continue;
        }
        if f["class"].is_null() {
            successes += 1;
        } else {
            failed += 1;
        }
        let short: String = f["checkpoint"]
            .as_str()
            .unwrap()
            .trim_start_matches("bundled:")
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let name = format!(
            "{}-{short}-S8-N4-seed{}.rrd",
            f["kind"].as_str().unwrap(),
            f["seed"]
        );
        assert!(recorded.contains(&name), "{name} not in {recorded:?}");
    }
    assert_eq!(recorded.len(), seen.len(), "{recorded:?}");
    assert!(
        seen.len() < failures.len(),
        "no episode was listed twice: {failures:?}"
    );
    assert!(
        stdout(&o).contains(&format!(
            "recorded {failed} failed episode(s) and {successes} success(es) listed for their low acc_cmb"
        )),
        "{}",
        stdout(&o)
    );
}

/// Without `--checkpoint`, `replay` and `eval` open a model by `view`'s rule: the paper's
/// where it reads the level's missions, `bundled:babyai` where it does not — said on stderr,
/// never silently (issue #66).
#[test]
fn without_a_checkpoint_every_command_opens_a_model_that_reads_the_level() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.json");
    let o = gs(&[
        "replay",
        "--level",
        "BabyAI-GoToDoor-v0",
        "--seed",
        "2",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cannot read the missions of")
            && stderr(&o).contains("opening bundled:babyai"),
        "{}",
        stderr(&o)
    );
    let o = gs(&[
        "replay",
        "--level",
        "BabyAI-GoToLocal-v0",
        "--seed",
        "2",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("opening"), "{}", stderr(&o));
    let out = dir.path().join("e");
    let o = gs(&[
        "eval",
        "--levels",
        "BabyAI-GoToDoor-v0",
        "--seeds",
        "1",
        "--episodes",
        "2",
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("opening bundled:babyai"),
        "{}",
        stderr(&o)
    );
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("- `bundled:babyai`") && !md.contains("- `bundled:attention`"),
        "{md}"
    );
}

/// `train --help` groups its flags under headings, and `eval --help` shows `--levels`.
#[test]
fn help_groups_trains_flags_and_shows_a_levels_sweep() {
    let out = stdout(&gs(&["train", "--help"]));
    let mut at = 0;
    for heading in [
        "Level:",
        "PPO:",
        "Imitation:",
        "Maps:",
        "Tracked evaluation:",
        "Model:",
    ] {
        let i = out
            .find(&format!("\n{heading}\n"))
            .unwrap_or_else(|| panic!("{heading}: {out}"));
        assert!(i > at, "{heading} out of order");
        at = i;
    }
    let ppo = &out[out.find("\nPPO:\n").unwrap()..out.find("\nImitation:\n").unwrap()];
    assert!(
        ppo.contains("--entropy-coef") && !ppo.contains("--ground-loss"),
        "{ppo}"
    );
    let eval = stdout(&gs(&["eval", "--help"]));
    assert!(
        eval.contains("groundscope eval --checkpoint bundled:babyai --levels "),
        "{eval}"
    );
}
