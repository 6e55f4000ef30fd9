//! `train`, `validate` and `curve` on the command line: exact resume, `--init`, the tracked
//! evaluation and the figures drawn from run logs.

use crate::common::{assert_bad_input, gs, stderr};

use std::path::Path;
use std::process::Output;

fn train(dir: &Path, frames: &str, extra: &[&str]) -> Output {
    gs(&train_args(dir, frames, extra))
}

/// The arguments of a small training run (tracked every 2 updates on 4 episodes).
fn train_args<'a>(dir: &'a Path, frames: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "train",
        "--model",
        "attention",
        "--out",
        dir.to_str().unwrap(),
        "--frames",
        frames,
        "--size",
        "5",
        "--objects",
        "1",
        "--tasks",
        "goto",
        "--no-done",
        "--procs",
        "4",
        "--frames-per-proc",
        "16",
        "--batch-size",
        "32",
        "--hidden",
        "16",
        "--save-interval",
        "1",
        "--eval-interval",
        "2",
        "--eval-episodes",
        "4",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    args
}

#[test]
fn validate_scores_a_saved_checkpoint_as_the_run_tracked_it() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    assert_eq!(train(&run, "256", &[]).status.code(), Some(0));
    let model = run.join("model");
    let out = dir.path().join("v.csv");
    let o = gs(&[
        "validate",
        model.to_str().unwrap(),
        "--episodes",
        "4",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Compared without the timing column: the same weights on the same held-out levels.
    let strip = |l: &str| l.rsplit_once(',').unwrap().0.to_owned();
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(rows.len(), 2, "{text}");
    assert!(rows[0].starts_with("checkpoint,update,frames,"), "{text}");
    let tracked = std::fs::read_to_string(run.join("eval_log.csv")).unwrap();
    let last = tracked.lines().last().unwrap();
    // Both files end with eval_secs (timing) and then level (empty for a one-level run).
    assert_eq!(
        strip(&strip(rows[1])),
        format!("{},{}", model.display(), strip(&strip(last)))
    );
    // A missing checkpoint is named, exits 2 and writes nothing.
    let missing = dir.path().join("nope");
    let out2 = dir.path().join("v2.csv");
    let o = gs(&[
        "validate",
        model.to_str().unwrap(),
        missing.to_str().unwrap(),
        "--out",
        out2.to_str().unwrap(),
    ]);
    assert_bad_input(&o, "nope");
    assert!(!out2.exists());
    assert_bad_input(
        &gs(&["validate", model.to_str().unwrap(), "--episodes", "0"]),
        "--episodes",
    );
    // An output that could not be written is refused before any evaluation.
    let m = model.to_str().unwrap();
    assert_bad_input(&gs(&["validate", m, "--out", "v.png"]), "--out");
    let nowhere = dir.path().join("no/such/dir/v.csv");
    assert_bad_input(
        &gs(&["validate", m, "--out", nowhere.to_str().unwrap()]),
        "cannot write",
    );
}

#[test]
fn model_options_train_resume_and_are_kept() {
    // (flag, its checkpoint field, the value under test, another valid one, an invalid one)
    for (flag, field, value, other, bad) in [
        ("--conv-kernel", "conv_kernel", "1", "3", "2"),
        ("--filter-scale", "filter_scale", "1", "49", "7"),
        ("--colour-codes", "colour_codes", "objects", "all", "none"),
        (
            "--colour-codes",
            "colour_codes",
            "walls-objects",
            "all",
            "walls",
        ),
        ("--word-temperature", "word_temperature", "3.89", "1", "0"),
        ("--key-kernel", "key_kernel", "1", "shared", "2"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let run = dir.path().join("run");
        let o = train(&run, "128", &[flag, value]);
        assert_eq!(o.status.code(), Some(0), "{flag}: {}", stderr(&o));
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(run.join("model.json")).unwrap())
                .unwrap();
        let kept = &meta["model"][field];
        assert_eq!(
            kept.as_str()
                .map_or_else(|| kept.to_string(), str::to_owned),
            value,
            "{meta}"
        );
        // A resume without the flag keeps the run's value; one with another is refused.
        let o = train(&run, "256", &["--resume"]);
        assert_eq!(o.status.code(), Some(0), "{flag}: {}", stderr(&o));
        assert_bad_input(
            &train(&run, "384", &["--resume", flag, other]),
            &format!("{flag} {value}, not {other}"),
        );
        // --init from it with another value is refused too, and leaves no run behind.
        let warm = dir.path().join("warm");
        let model = run.join("model");
        assert_bad_input(
            &train(
                &warm,
                "128",
                &["--init", model.to_str().unwrap(), flag, other],
            ),
            &format!("not {flag} {other}"),
        );
        assert!(!warm.exists());
        // An unsupported value is refused before a new run leaves anything.
        let refused = dir.path().join("bad");
        assert_bad_input(
            &train(&refused, "128", &[flag, bad]),
            &format!("{field} = {bad}"),
        );
        assert!(!refused.exists());
    }
}

#[test]
fn an_annealed_temperature_ends_at_the_papers_and_resumes_exactly() {
    // 64 frames per update: updates starting at 0 and 64 act at 3, then 2, then 1 from 192.
    let dir = tempfile::tempdir().unwrap();
    let anneal = [
        "--word-temperature",
        "3",
        "--word-temperature-anneal",
        "64:192",
    ];
    let temperature = |run: &Path| {
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(run.join("model.json")).unwrap())
                .unwrap();
        meta["model"]["word_temperature"].as_f64()
    };
    let whole = dir.path().join("whole");
    let o = train(&whole, "128", &anneal);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // The second update started at 64 frames: still 3.
    assert_eq!(temperature(&whole), Some(3.0));
    let o = train(&whole, "192", &["--resume"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(temperature(&whole), Some(2.0));
    let o = train(&whole, "320", &["--resume"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // At 1 the model is the paper's, and its checkpoint leaves the field out.
    assert_eq!(temperature(&whole), None);
    let straight = dir.path().join("straight");
    let o = train(&straight, "320", &anneal);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(whole.join("model.safetensors")).unwrap(),
        std::fs::read(straight.join("model.safetensors")).unwrap(),
        "a run resumed twice ends with other weights than an uninterrupted one"
    );
    assert_bad_input(
        &train(
            &whole,
            "384",
            &["--resume", "--word-temperature-anneal", "0:64"],
        ),
        "--word-temperature-anneal 64:192, not 0:64",
    );
    for bad in ["64", "192:64", "a:b", "-1:5"] {
        let refused = dir.path().join("bad");
        assert_bad_input(
            &train(&refused, "128", &["--word-temperature-anneal", bad]),
            "--word-temperature-anneal",
        );
        assert!(!refused.exists(), "{bad}");
    }
}

#[test]
fn a_resume_that_leaves_out_the_tracking_flags_tracks_as_the_run_did() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    assert_eq!(train(&run, "128", &[]).status.code(), Some(0));
    // Without the run's settings the defaults (every 50 updates, 200 episodes) would apply.
    let mut args = train_args(&run, "256", &["--resume"]);
    let at = args.iter().position(|a| *a == "--eval-interval").unwrap();
    args.drain(at..at + 4);
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // A flag given on resume wins, and is kept for the next resume.
    let mut args = train_args(&run, "384", &["--resume", "--eval-episodes", "6"]);
    args.drain(at..at + 4);
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut args = train_args(&run, "512", &["--resume"]);
    args.drain(at..at + 4);
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let rows: Vec<String> = std::fs::read_to_string(run.join("eval_log.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').take(3).collect::<Vec<_>>().join(","))
        .collect();
    assert_eq!(
        rows,
        ["2,128,4", "4,256,4", "6,384,6", "8,512,6"],
        "{rows:?}"
    );
}

#[test]
fn resumed_training_matches_an_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let straight = dir.path().join("straight");
    let split = dir.path().join("split");
    assert_eq!(train(&straight, "256", &[]).status.code(), Some(0));
    assert_eq!(train(&split, "128", &[]).status.code(), Some(0));
    // As if the run had been killed after logging update 3 but before checkpointing it.
    let log_path = split.join("log.csv");
    let text = std::fs::read_to_string(&log_path).unwrap();
    let last = text.lines().last().unwrap();
    let ghost = format!("3{}\n", &last[last.find(',').unwrap()..]);
    std::fs::write(&log_path, text + &ghost).unwrap();
    let o = train(&split, "256", &["--resume"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for f in [
        "model.safetensors",
        "checkpoints/update-00000004/optimizer.safetensors",
    ] {
        assert_eq!(
            std::fs::read(straight.join(f)).unwrap(),
            std::fs::read(split.join(f)).unwrap(),
            "{f} differs"
        );
    }
    let log = |d: &Path| {
        std::fs::read_to_string(d.join("log.csv"))
            .unwrap()
            .lines()
            .map(|l| {
                l.split(',')
                    .enumerate()
                    .filter(|(i, _)| ![2, 11].contains(i))
                    .map(|(_, x)| x.to_owned())
                    .collect::<Vec<_>>()
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(
        log(&straight),
        log(&split),
        "same losses apart from timing columns"
    );
    // The tracked evaluation runs at updates 2 and 4 in both, with the same results.
    let evals = |d: &Path| -> Vec<String> {
        std::fs::read_to_string(d.join("eval_log.csv"))
            .unwrap()
            .lines()
            // All but the trailing eval_secs (timing) and level columns.
            .map(|l| l.rsplitn(3, ',').nth(2).unwrap().to_owned())
            .collect()
    };
    assert_eq!(evals(&straight), evals(&split));
    assert_eq!(evals(&straight).len(), 3, "{:?}", evals(&straight));
    assert!(evals(&straight)[2].starts_with("4,256,4,"));
    // A resume directory from another model, and a fresh run over an existing one.
    let mut args = vec![
        "train",
        "--model",
        "baseline",
        "--out",
        split.to_str().unwrap(),
        "--resume",
        "--quiet",
    ];
    assert_bad_input(&gs(&args), "attention");
    args.retain(|a| *a != "--resume");
    assert_bad_input(&gs(&args), "--resume");
    // Flags given with --resume must agree with the run; flags left out take its values.
    let before = std::fs::read(split.join("model.safetensors")).unwrap();
    assert_bad_input(
        &train(&split, "320", &["--resume", "--lr", "0.5"]),
        "--lr 0.001",
    );
    assert_bad_input(
        &train(&split, "320", &["--resume", "--always-color"]),
        "--always-color",
    );
    assert_eq!(
        std::fs::read(split.join("model.safetensors")).unwrap(),
        before,
        "a refused resume leaves the run alone"
    );
    assert_bad_input(
        &train(&dir.path().join("x"), "64", &["--recurrence", "3"]),
        "--recurrence",
    );
    assert_bad_input(
        &train(Path::new("/proc/groundscope-run"), "64", &[]),
        "groundscope-run",
    );
}

#[test]
fn init_starts_a_new_run_from_trained_weights() {
    let dir = tempfile::tempdir().unwrap();
    let parent = dir.path().join("parent");
    assert_eq!(train(&parent, "128", &[]).status.code(), Some(0));
    let child = dir.path().join("child");
    let init = parent.join("model");
    let o = train(
        &child,
        "256",
        &["--init", init.to_str().unwrap(), "--entropy-coef", "0.001"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let meta = |d: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join("model.json")).unwrap()).unwrap()
    };
    // 128 frames = 2 updates of 64 in the parent, then 2 more here.
    assert_eq!(meta(&parent)["training"]["updates"], 2);
    assert_eq!(meta(&child)["training"]["frames"], 256);
    assert_eq!(meta(&child)["training"]["updates"], 4);
    assert_ne!(
        meta(&parent)["weights_sha256"],
        meta(&child)["weights_sha256"]
    );
    let updates = |d: &Path| -> Vec<String> {
        std::fs::read_to_string(d.join("log.csv"))
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').next().unwrap().to_owned())
            .collect()
    };
    assert_eq!(
        updates(&child),
        ["1", "2", "3", "4"],
        "the parent's rows come first"
    );
    let parent_log = std::fs::read_to_string(parent.join("log.csv")).unwrap();
    let child_log = std::fs::read_to_string(child.join("log.csv")).unwrap();
    assert!(child_log.starts_with(&parent_log));
    // The run directory names its model, and its logs are found inside it.
    let sibling = dir.path().join("sibling");
    let o = train(&sibling, "256", &["--init", parent.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(updates(&sibling), ["1", "2", "3", "4"]);
    let sibling_log = std::fs::read_to_string(sibling.join("log.csv")).unwrap();
    assert!(sibling_log.starts_with(&parent_log));
    // The child resumes like any run; --init with --resume, or of the other model, is refused.
    let o = train(&child, "320", &["--resume"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(meta(&child)["training"]["updates"], 5);
    assert_bad_input(
        &train(
            &child,
            "384",
            &["--resume", "--init", init.to_str().unwrap()],
        ),
        "--init",
    );
    let o = gs(&[
        "train",
        "--model",
        "baseline",
        "--init",
        init.to_str().unwrap(),
        "--out",
        dir.path().join("b").to_str().unwrap(),
        "--quiet",
    ]);
    assert_bad_input(&o, "attention");
    assert!(!dir.path().join("b").join("model.json").exists());
}

#[test]
fn a_run_with_frozen_maps_resumes_exactly_and_keeps_its_freeze() {
    // 64 frames per update: the maps train for two updates, then stop.
    let dir = tempfile::tempdir().unwrap();
    let freeze = ["--freeze-attention-at", "128"];
    let whole = dir.path().join("whole");
    let o = train(&whole, "128", &freeze);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // The resume leaves the flag out and keeps the run's.
    let o = train(&whole, "320", &["--resume"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let straight = dir.path().join("straight");
    let o = train(&straight, "320", &freeze);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(whole.join("model.safetensors")).unwrap(),
        std::fs::read(straight.join("model.safetensors")).unwrap(),
        "a resumed run with a freeze ends with other weights than an uninterrupted one"
    );
    assert_bad_input(
        &train(&whole, "384", &["--resume", "--freeze-attention-at", "64"]),
        "--freeze-attention-at 128, not 64",
    );
    let refused = dir.path().join("baseline");
    let mut args = train_args(&refused, "128", &freeze);
    let at = args.iter().position(|a| *a == "attention").unwrap();
    args[at] = "baseline";
    assert_bad_input(&gs(&args), "--freeze-attention-at");
    assert!(!refused.exists());
    for bad in ["-1", "x"] {
        assert_bad_input(
            &train(&refused, "128", &["--freeze-attention-at", bad]),
            "--freeze-attention-at",
        );
        assert!(!refused.exists(), "{bad}");
    }
}

/// The arguments of a small imitation run on a BabyAI level (`train --imitate`).
fn imitate_args<'a>(dir: &'a Path, frames: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "train",
        "--imitate",
        "--model",
        "attention",
        "--level",
        "BabyAI-GoToLocalS6N3-v0",
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
        "4",
        "--eval-episodes",
        "8",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    args
}

/// Imitation of the bot: the cross-entropy on its actions falls, the demonstrations succeed
/// (the bot solves the level), and a run resumed mid-episode — the bot's plan saved with each
/// environment — ends with the weights of an uninterrupted one; the flag is kept on resume
/// and a PPO run cannot be resumed as an imitation one.
#[test]
fn imitation_learns_the_bots_actions_and_resumes_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let straight = dir.path().join("straight");
    let o = gs(&imitate_args(&straight, "1536", &[]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let log = std::fs::read_to_string(straight.join("log.csv")).unwrap();
    let rows: Vec<Vec<String>> = log
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    assert_eq!(rows.len(), 12);
    let loss = |r: &Vec<String>| r[7].parse::<f64>().unwrap();
    assert!(
        loss(&rows[11]) < 0.8 * loss(&rows[0]),
        "the cross-entropy on the bot's actions falls: {log}"
    );
    // The demonstrations are the bot's: they succeed whenever an episode ends.
    for r in &rows {
        if r[3] != "0" {
            assert_eq!(r[4], "1.0000", "{log}");
        }
    }
    let whole = dir.path().join("whole");
    let o = gs(&imitate_args(&whole, "640", &[]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut resume = imitate_args(&whole, "1536", &["--resume"]);
    resume.retain(|a| *a != "--imitate");
    let o = gs(&resume);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(whole.join("model.safetensors")).unwrap(),
        std::fs::read(straight.join("model.safetensors")).unwrap(),
        "a resumed imitation run ends with other weights than an uninterrupted one"
    );
    // A PPO run is not continued as imitation.
    let ppo = dir.path().join("ppo");
    let mut args = imitate_args(&ppo, "128", &[]);
    args.retain(|a| *a != "--imitate");
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_bad_input(&gs(&imitate_args(&ppo, "256", &["--resume"])), "--imitate");
}

/// #81's split points: GoToObj stopped at update 30 or 38 and resumed ended with weights
/// 1e-8 to 1e-6 away from the uninterrupted run's, because the rollout's mission cache
/// (which decides the batch the missions' inputs are computed in) started empty again.
#[test]
fn a_run_resumed_at_any_update_ends_with_the_uninterrupted_runs_weights() {
    let dir = tempfile::tempdir().unwrap();
    let args = |run: &Path, frames: &str, resume: bool| {
        let mut a = vec![
            "train".to_string(),
            "--model".into(),
            "attention".into(),
            "--level".into(),
            "BabyAI-GoToObj-v0".into(),
            "--seed".into(),
            "1".into(),
            "--procs".into(),
            "2".into(),
            "--frames-per-proc".into(),
            "16".into(),
            "--batch-size".into(),
            "32".into(),
            "--epochs".into(),
            "1".into(),
            "--hidden".into(),
            "16".into(),
            "--eval-interval".into(),
            "0".into(),
            "--quiet".into(),
            "--frames".into(),
            frames.into(),
            "--out".into(),
            run.to_str().unwrap().into(),
        ];
        if resume {
            a.push("--resume".into());
        }
        a
    };
    let run = |a: Vec<String>| {
        let refs: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = gs(&refs);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    };
    // 32 frames an update: 1,600 frames are update 50.
    let whole = dir.path().join("whole");
    run(args(&whole, "1600", false));
    for stop in [30u64, 38] {
        let split = dir.path().join(format!("split{stop}"));
        run(args(&split, &(stop * 32).to_string(), false));
        run(args(&split, "1600", true));
        assert_eq!(
            std::fs::read(split.join("model.safetensors")).unwrap(),
            std::fs::read(whole.join("model.safetensors")).unwrap(),
            "stopped at update {stop} and resumed, the weights differ from the uninterrupted run's"
        );
    }
}
