//! Bad and hostile inputs read from files and given as text: dumps `env verify` checks, FIFOs
//! named as checkpoints or logs, training logs `curve` draws, missions, level ids and word
//! temperatures; one-line errors with exit 2, no panics. (Split from `reliability::outputs`.)

use crate::common::{self, assert_bad_input, gs, train_tiny as train};

#[test]
fn env_verify_compares_directions_and_missions_and_rejects_malformed_images() {
    let tmp = tempfile::tempdir().unwrap();
    let src = std::fs::read_to_string(&common::fixtures("minigrid")[0]).unwrap();
    let write = |name: &str, v: &serde_json::Value| {
        let p = tmp.path().join(name);
        std::fs::write(&p, v.to_string()).unwrap();
        p.display().to_string()
    };
    let base: serde_json::Value = serde_json::from_str(&src).unwrap();
    assert!(!base["steps"].as_array().unwrap().is_empty());
    for (name, edit) in [
        (
            "dir.json",
            &(|v: &mut serde_json::Value| v["steps"][0]["direction"] = 1000.into())
                as &dyn Fn(&mut serde_json::Value),
        ),
        ("idir.json", &|v| {
            let d = v["initial_obs"]["direction"].as_i64().unwrap();
            v["initial_obs"]["direction"] = ((d + 1) % 4).into();
        }),
        ("imission.json", &|v| {
            v["initial_obs"]["mission"] = "go to the red ball".into();
        }),
    ] {
        let mut v = base.clone();
        edit(&mut v);
        let o = gs(&["env", "verify", &write(name, &v)]);
        assert_eq!(o.status.code(), Some(1), "{name} is a mismatch");
    }
    let mut v = base.clone();
    v["steps"][0]["image"][2][3] = serde_json::json!([-1, 0, 0]);
    assert_bad_input(
        &gs(&["env", "verify", &write("code.json", &v)]),
        "steps[0].image[2][3]",
    );
    let mut v = base.clone();
    v["steps"][0]["image"] = serde_json::json!([[[1, 0, 0]]]);
    assert_bad_input(&gs(&["env", "verify", &write("len.json", &v)]), "7×7");
    let mut v = base;
    v["grid"][2][3] = serde_json::json!([0, 0, 0]);
    assert_bad_input(&gs(&["env", "verify", &write("unseen.json", &v)]), "unseen");
}

/// A dump missing a required field is refused naming it by its path, not by a line and
/// column; `env verify` checks every file it is given and ends with its summary, exit 2 when
/// one was bad input (it used to stop at the first malformed file).
#[test]
fn env_verify_names_missing_fields_and_checks_every_file() {
    let tmp = tempfile::tempdir().unwrap();
    let src = groundscope::files::read_text_maybe_gz(&common::fixtures("babyai")[0]).unwrap();
    let base: serde_json::Value = serde_json::from_str(&src).unwrap();
    let write = |name: &str, v: &serde_json::Value, pretty: bool| {
        let p = tmp.path().join(name);
        let text = if pretty {
            serde_json::to_string_pretty(v).unwrap()
        } else {
            v.to_string()
        };
        std::fs::write(&p, text).unwrap();
        p.display().to_string()
    };
    for field in ["seed", "grid", "mission", "instr", "width", "agent_pos"] {
        for pretty in [false, true] {
            let mut v = base.clone();
            v.as_object_mut().unwrap().remove(field);
            let f = write(&format!("no_{field}.json"), &v, pretty);
            let o = gs(&["env", "verify", &f]);
            assert_bad_input(&o, &format!("{f}: invalid snapshot: {field}: "));
            assert!(
                !common::stderr(&o).contains("line 1 column"),
                "{}",
                common::stderr(&o)
            );
        }
    }
    let mut v = base.clone();
    v["steps"][1].as_object_mut().unwrap().remove("action");
    let f = write("no_action.json", &v, true);
    assert_bad_input(
        &gs(&["env", "verify", &f]),
        "steps[1].action: missing (a required field)",
    );
    let mut v = base.clone();
    v["instr"].as_object_mut().unwrap().remove("kind");
    let f = write("no_kind.json", &v, false);
    assert_bad_input(&gs(&["env", "verify", &f]), "instr.kind: missing");
    let mut v = base.clone();
    v["steps"][0]["reward"] = "high".into();
    let f = write("reward.json", &v, false);
    assert_bad_input(&gs(&["env", "verify", &f]), "steps[0].reward: invalid type");

    // Good, malformed, mismatching, good: every file is checked.
    let good = write("good.json", &base, false);
    let mut v = base.clone();
    v.as_object_mut().unwrap().remove("grid");
    let bad = write("bad.json", &v, false);
    let mut v = base;
    v["seed"] = (v["seed"].as_u64().unwrap() + 1).into();
    let other = write("other.json", &v, false);
    let o = gs(&["env", "verify", &good, &bad, &other, &good]);
    assert_bad_input(&o, &format!("{bad}: invalid snapshot: grid: missing"));
    let out = common::stdout(&o);
    assert!(out.contains(&format!("{other}: step 0: ")), "{out}");
    assert!(
        out.ends_with("2 passed, 1 failed, 1 refused (bad input)\n"),
        "{out}"
    );
    let o = gs(&["env", "verify", &good, &other]);
    assert_eq!(o.status.code(), Some(1));
    assert!(common::stdout(&o).ends_with("1 passed, 1 failed\n"));
}

/// A dump may hold at most 64 MiB of text: a small gzip of whitespace that expands past that
/// (6.5 MB took 3.6 GB) is refused as it expands, a plain file by its size, each in one line
/// naming the file.
#[test]
fn env_verify_bounds_what_a_dump_expands_to() {
    use std::io::Write as _;
    let tmp = tempfile::tempdir().unwrap();
    let max = groundscope::files::TEXT_BYTES_MAX;
    assert_eq!(max, 64 << 20, "docs/formats.md says 64 MiB");
    let bomb = tmp.path().join("bomb.json.gz");
    let mut gz = flate2::write::GzEncoder::new(
        std::fs::File::create(&bomb).unwrap(),
        flate2::Compression::fast(),
    );
    let spaces = vec![b' '; 1 << 20];
    for _ in 0..=(max >> 20) {
        gz.write_all(&spaces).unwrap();
    }
    gz.finish().unwrap();
    assert!(std::fs::metadata(&bomb).unwrap().len() < 1 << 20);
    let o = gs(&["env", "verify", bomb.to_str().unwrap()]);
    assert_bad_input(
        &o,
        &format!("reading {}: expands to more than 64 MiB", bomb.display()),
    );
    let big = tmp.path().join("big.json");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(max + 1)
        .unwrap();
    let o = gs(&["env", "verify", big.to_str().unwrap()]);
    assert_bad_input(
        &o,
        &format!("reading {}: holds more than 64 MiB", big.display()),
    );
}

#[test]
fn bench_train_reports_every_phase() {
    let o = gs(&["bench", "train", "--frames", "2048"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["bench"], "train");
    assert_eq!(j["frames"], 2048);
    let phases = j["phase_seconds"].as_object().unwrap();
    let mut names: Vec<&str> = phases.keys().map(String::as_str).collect();
    names.sort_unstable();
    let mut want = [
        "rollout_env",
        "rollout_encode",
        "rollout_forward",
        "gae",
        "update_encode",
        "update_forward",
        "update_backward",
        "optimizer",
    ];
    want.sort_unstable();
    assert_eq!(names, want, "every phase, and no other");
    // The report adds up, whatever the clock read: the phases (rounded to milliseconds) and
    // the untimed rest make the total, and one update thread runs the phases one after the
    // other inside the timed loop, so they cannot add up to more than it.
    let seconds = j["seconds"].as_f64().unwrap();
    let untimed = j["untimed_seconds"].as_f64().unwrap();
    let timed: f64 = phases.values().map(|v| v.as_f64().unwrap()).sum();
    assert!(untimed >= 0.0, "phases overlap: {timed} s of {seconds} s");
    assert!(
        (timed + untimed - seconds).abs() <= 8.0 * 0.0005 + 1e-9,
        "{timed} + {untimed} != {seconds}"
    );
    assert_eq!(
        j["frames_per_sec"].as_f64().unwrap(),
        (2048.0 / seconds).round()
    );
    assert_bad_input(&gs(&["bench", "train", "--frames", "10"]), "--frames");
}

/// A FIFO (or any non-regular file) named as a checkpoint, ONNX graph or training log is
/// refused by name at once: opening a FIFO for reading would wait for a writer forever.
#[cfg(unix)]
#[test]
fn fifos_are_refused_not_waited_on() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = |name: &str| {
        let p = dir.path().join(name);
        let ok = std::process::Command::new("mkfifo")
            .arg(&p)
            .status()
            .unwrap();
        assert!(ok.success(), "mkfifo {name}");
        p.display().to_string()
    };
    let onnx = fifo("agent.onnx");
    let json = fifo("model.json");
    std::fs::write(dir.path().join("model.safetensors"), b"x").unwrap();
    let model = dir.path().join("model").display().to_string();
    let log = fifo("log.csv");
    let out = dir.path().join("c.png").display().to_string();
    for (args, what) in [
        (vec!["replay", "--checkpoint", onnx.as_str()], "agent.onnx"),
        (vec!["validate", onnx.as_str()], "agent.onnx"),
        (vec!["replay", "--checkpoint", model.as_str()], "model.json"),
        (
            vec!["curve", log.as_str(), "--out", out.as_str()],
            "log.csv",
        ),
    ] {
        let o = common::gs_guarded(&args);
        assert_bad_input(&o, what);
        assert!(
            common::stderr(&o).contains("FIFO"),
            "{}",
            common::stderr(&o)
        );
    }
    assert!(!std::path::Path::new(&out).exists());
    let _ = json;
}

/// A training log with an infinite (or NaN) value on an axis is refused naming the line and
/// column; `curve` used to loop forever drawing an axis to infinity.
#[test]
fn curve_refuses_non_finite_values() {
    let dir = tempfile::tempdir().unwrap();
    let header = "update,frames,fps,episodes,success_rate,mean_reward,mean_length,policy_loss,value_loss,entropy,grad_norm,elapsed_secs";
    for (bad, column) in [
        ("inf", "frames"),
        ("NaN", "frames"),
        ("-inf", "mean_reward"),
    ] {
        let (frames, reward) = if column == "frames" {
            (bad, "0.5")
        } else {
            ("4096", bad)
        };
        let text = format!(
            "{header}\n1,2048,2659,326,0.0184,0.0157,5.99,-0.04,0.01,1.93,0.09,0.8\n2,{frames},2970,359,0.0111,{reward},5.80,0.02,0.006,1.92,0.05,1.4\n"
        );
        let log = dir.path().join("log.csv");
        std::fs::write(&log, text).unwrap();
        let out = dir.path().join("c.png");
        let o = common::gs_guarded(&[
            "curve",
            log.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_bad_input(&o, &format!("line 3 column {column}"));
        assert!(!out.exists(), "nothing written");
    }
}

/// An update that ends no episode logs `NaN` success, reward and length (documented): `curve`
/// draws such a log with a gap there, and a training's saves keep redrawing its curve.png.
/// `curve` used to refuse a run's own log, and every save printed an error instead.
#[test]
fn curve_draws_a_run_log_with_updates_that_ended_no_episode() {
    let dir = tempfile::tempdir().unwrap();
    let header = "update,frames,fps,episodes,success_rate,mean_reward,mean_length,policy_loss,value_loss,entropy,grad_norm,elapsed_secs";
    let log = dir.path().join("log.csv");
    std::fs::write(
        &log,
        format!(
            "{header}\n1,2048,2659,0,NaN,NaN,NaN,-0.04,0.01,1.93,0.09,0.8\n2,4096,2970,359,0.0111,0.0157,5.80,0.02,0.006,1.92,0.05,1.4\n"
        ),
    )
    .unwrap();
    let out = dir.path().join("c.png");
    let o = common::gs_guarded(&[
        "curve",
        log.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    assert!(out.exists());

    // A run whose long episodes end in no update of one frame per environment.
    let run = dir.path().join("run");
    let o = train(
        &run,
        &[
            "--procs",
            "1",
            "--frames-per-proc",
            "1",
            "--batch-size",
            "1",
            "--recurrence",
            "1",
            "--frames",
            "3",
            "--save-interval",
            "1",
            "--eval-interval",
            "0",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    let text = std::fs::read_to_string(run.join("log.csv")).unwrap();
    assert!(text.contains("NaN"), "an update ended no episode: {text}");
    assert!(
        !common::stderr(&o).contains("curve.png"),
        "{}",
        common::stderr(&o)
    );
    assert!(run.join("curve.png").exists());
    let out = dir.path().join("run.png");
    let o = common::gs_guarded(&[
        "curve",
        run.join("log.csv").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", common::stderr(&o));
    assert!(out.exists());
}

/// A word temperature small enough to underflow the word weights to NaN is refused.
#[test]
fn a_word_temperature_that_underflows_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m");
    for t in ["1e-45", "0.001"] {
        let o = gs(&[
            "init",
            "--model",
            "attention",
            "--word-temperature",
            t,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_bad_input(&o, "word_temperature");
        assert!(!dir.path().join("m.json").exists());
    }
}

/// `--jobs 0` is refused by `eval` as by `faithfulness`, before anything is written; user
/// text in an error is escaped and cut (control characters, a 10,000-character mission).
#[test]
fn one_jobs_rule_and_user_text_shown_safely() {
    let dir = tempfile::tempdir().unwrap();
    for cmd in ["eval", "faithfulness"] {
        let out = dir.path().join(cmd);
        let o = gs(&[
            cmd,
            "--jobs",
            "0",
            "--episodes",
            "1",
            "--seeds",
            "1",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_bad_input(&o, "--jobs 0");
        assert!(!out.exists(), "{cmd} wrote nothing");
    }
    let o = gs(&["replay", "--mission", "go to the \u{1b}[31mred key"]);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        !err.contains('\u{1b}') && err.contains("\\u{1b}"),
        "{err:?}"
    );
    let long = format!("go to the {} key", "x".repeat(10_000));
    let o = gs(&["replay", "--mission", &long]);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.len() < 500, "a {} byte error line", err.len());
}

/// A mission that is not a BabyAI instruction is refused naming the word at fault and its
/// position; the error used to say only "unexpected words after the object".
#[test]
fn a_mission_error_names_the_word_and_its_position() {
    for (mission, want) in [
        (
            "go to the red ball please",
            "word 6 \"please\": unexpected after the object",
        ),
        (
            "go to the red ball and",
            "after word 6 \"and\", the last: a clause",
        ),
        (
            "pick up the key, then go to the red lamp",
            "word 10 \"lamp\": not key",
        ),
    ] {
        assert_bad_input(
            &gs(&["replay", "--mission", mission]),
            &format!("invalid mission \"{mission}\": {want}"),
        );
    }
    let long = format!("go to the red ball {}", "x".repeat(10_000));
    let o = gs(&["replay", "--mission", &long]);
    assert_bad_input(&o, "word 6 \"xxxx");
    assert!(common::stderr(&o).len() < 700, "{} bytes", o.stderr.len());
}

/// A level id in an error is cut as a mission is (80 characters, then its length): a
/// 100,000-character `--level`, or `env_id` in a dump, used to give a 100 kB error line.
#[test]
fn long_level_ids_are_cut_in_errors() {
    let dir = tempfile::tempdir().unwrap();
    let long = format!("BabyAI-{}", "x".repeat(100_000));
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    for args in [
        vec!["env", "show", "--level", &long],
        vec!["replay", "--level", &long],
        vec!["train", "--out", o, "--level", &long],
        vec!["eval", "--out", o, "--levels", &long],
    ] {
        let r = gs(&args);
        assert_bad_input(&r, "(100007 characters)");
        assert!(
            common::stderr(&r).len() < 600,
            "{:?}: {} bytes",
            args[0],
            r.stderr.len()
        );
        assert!(!out.exists(), "{:?} wrote nothing", args[0]);
    }
    let src = groundscope::files::read_text_maybe_gz(&common::fixtures("babyai")[0]).unwrap();
    let base: serde_json::Value = serde_json::from_str(&src).unwrap();
    for (field, value) in [
        ("env_id", long.clone()),
        (
            "env_id",
            format!("groundscope-PaperLocalS{}8N4-v0", "0".repeat(100_000)),
        ),
        ("minigrid_version", "9".repeat(100_000)),
    ] {
        let mut v = base.clone();
        v[field] = value.into();
        let f = dir.path().join("dump.json");
        std::fs::write(&f, v.to_string()).unwrap();
        let r = gs(&["env", "verify", f.to_str().unwrap()]);
        assert_bad_input(&r, &format!("{field}: "));
        assert!(
            common::stderr(&r).len() < 600,
            "{field}: {} bytes",
            r.stderr.len()
        );
    }
}
