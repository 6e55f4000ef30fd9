//! Recordings read back: `.rrd` through Rerun's own decoder, MCAP through the `mcap` reader.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use groundscope::episode::{ActionMode, EpisodeSpec, EpisodeTrace, run_episode};
use groundscope::policy::bundled;
use groundscope::record::{RecordError, RerunTargets, record_rerun, write_mcap};

use crate::common::rrd::{Decoded, decode, rows};

fn episodes(model: &str, seeds: std::ops::Range<u64>) -> Vec<EpisodeTrace> {
    let spec_name = format!("bundled:{model}");
    let ckpt = bundled::load(&spec_name).unwrap();
    seeds
        .map(|seed| {
            let spec = EpisodeSpec {
                level: ckpt.meta.level,
                seed,
                mission: None,
                mode: ActionMode::Greedy,
            };
            run_episode(&ckpt, &spec_name, &spec).unwrap()
        })
        .collect()
}

#[test]
fn rrd_holds_every_step_at_the_documented_entity_paths() {
    let eps = episodes("attention", 3..5);
    let steps: usize = eps.iter().map(|e| e.steps.len()).sum();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.rrd");
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    let stats = record_rerun(&eps, &targets, 0.5, None).unwrap();
    assert_eq!(stats.steps, steps);
    assert_eq!(stats.episodes, 2);
    // Only the finished file is left in the directory.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(names, ["two.rrd"]);

    let d = decode(&path);
    assert!(d.versions.contains("0.36.3"), "{:?}", d.versions);
    assert!(d.blueprints > 0, "a default blueprint is written");
    for entity in [
        "/world/grid",
        "/view/image",
        "/policy/probs",
        "/policy/value",
        "/policy/reward",
        "/policy/status",
    ] {
        let n: usize = d
            .rows
            .iter()
            .filter(|((e, _), _)| e == entity)
            .map(|(_, n)| *n)
            .max()
            .unwrap_or(0);
        assert_eq!(n, steps, "{entity} should have one row per step");
    }
    assert_eq!(rows(&d, "/world/grid", "Image:buffer"), steps);
    assert_eq!(rows(&d, "/attention/combined", "DepthImage:buffer"), steps);
    assert_eq!(rows(&d, "/attention/weights", "Points2D:labels"), steps);
    assert_eq!(rows(&d, "/world/attention", "Image:buffer"), steps);
    for (e, ep) in eps.iter().enumerate() {
        for (i, w) in ep.words().iter().enumerate() {
            let path = format!("/attention/words/{i}_{w}");
            assert!(
                rows(&d, &path, "DepthImage:buffer") >= ep.steps.len(),
                "episode {e}: {path} is missing"
            );
            assert!(rows(&d, &format!("{path}/label"), "Boxes2D:half_sizes") > 0);
        }
    }
    for entity in ["/meta", "/world/attention"] {
        assert!(d.static_entities.contains(entity), "{entity} is static");
    }
    // Values against the traces, in step order.
    let values: Vec<f64> = eps
        .iter()
        .flat_map(|e| e.steps.iter().map(|s| f64::from(s.value)))
        .collect();
    let logged: Vec<f64> = d.scalars["/policy/value"].iter().map(|v| v[0]).collect();
    assert_eq!(logged, values);
    let rewards: Vec<f64> = eps
        .iter()
        .flat_map(|e| e.steps.iter().map(|s| s.reward))
        .collect();
    let logged: Vec<f64> = d.scalars["/policy/reward"].iter().map(|v| v[0]).collect();
    assert_eq!(logged, rewards);
}

#[test]
fn rrd_of_the_same_episodes_decodes_identically() {
    let eps = episodes("attention", 7..8);
    let dir = tempfile::tempdir().unwrap();
    let decoded: Vec<Decoded> = ["a.rrd", "b.rrd"]
        .iter()
        .map(|name| {
            let path = dir.path().join(name);
            let targets = RerunTargets {
                save: Some(path.clone()),
                ..RerunTargets::default()
            };
            record_rerun(&eps, &targets, 0.5, None).unwrap();
            decode(&path)
        })
        .collect();
    assert_eq!(decoded[0], decoded[1]);
}

#[test]
fn baseline_recordings_have_no_attention_entities() {
    let eps = episodes("baseline", 1..2);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("b.rrd");
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    record_rerun(&eps, &targets, 0.5, None).unwrap();
    let d = decode(&path);
    assert_eq!(rows(&d, "/world/grid", "Image:buffer"), eps[0].steps.len());
    assert!(
        !d.rows.keys().any(|(e, _)| e.starts_with("/attention/")),
        "{:?}",
        d.rows.keys().collect::<Vec<_>>()
    );
}

#[test]
fn recording_failures_leave_no_file() {
    let eps = episodes("attention", 3..4);
    let dir = tempfile::tempdir().unwrap();
    // Interrupted before the first step.
    let stop = Arc::new(AtomicBool::new(true));
    let path = dir.path().join("x.rrd");
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    let err = record_rerun(&eps, &targets, 0.5, Some(&stop)).unwrap_err();
    assert!(matches!(err, RecordError::Interrupted), "{err}");
    let err = write_mcap(&eps, &dir.path().join("x.mcap"), 0.5, Some(&stop)).unwrap_err();
    assert!(matches!(err, RecordError::Interrupted), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    // A directory that does not exist.
    let missing = dir.path().join("no/such/dir/x.rrd");
    let targets = RerunTargets {
        save: Some(missing.clone()),
        ..RerunTargets::default()
    };
    let err = record_rerun(&eps, &targets, 0.5, None).unwrap_err();
    assert!(err.to_string().contains("no/such/dir/x.rrd"), "{err}");
    // No viewer listening: a free port, found by binding and releasing it.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let targets = RerunTargets {
        connect: Some(format!("rerun+http://127.0.0.1:{port}/proxy")),
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    let err = record_rerun(&eps, &targets, 0.5, None).unwrap_err();
    assert!(matches!(err, RecordError::NoViewer { .. }), "{err}");
    let targets = RerunTargets {
        connect: Some("http://nonsense".into()),
        ..RerunTargets::default()
    };
    assert!(record_rerun(&eps, &targets, 0.5, None).is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn mcap_has_foxglove_topics_and_one_message_per_step() {
    let eps = episodes("attention", 3..5);
    let steps: usize = eps.iter().map(|e| e.steps.len()).sum();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.mcap");
    let stats = write_mcap(&eps, &path, 0.5, None).unwrap();
    assert_eq!(stats.steps, steps);
    let bytes = std::fs::read(&path).unwrap();
    assert!(
        mcap::read::Summary::read(&bytes).unwrap().is_some(),
        "summary"
    );
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    let mut schemas: BTreeMap<String, String> = BTreeMap::new();
    let mut values = Vec::new();
    let mut last_time = 0;
    for msg in mcap::MessageStream::new(&bytes).unwrap() {
        let msg = msg.unwrap();
        let topic = msg.channel.topic.clone();
        assert_eq!(msg.channel.message_encoding, "json");
        let schema = msg.channel.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "jsonschema");
        schemas.insert(topic.clone(), schema.name.clone());
        *counts.entry(topic.clone()).or_default() += 1;
        assert!(msg.log_time >= last_time, "messages in time order");
        last_time = msg.log_time;
        let v: serde_json::Value = serde_json::from_slice(&msg.data).unwrap();
        if topic == "/policy" {
            values.push(v["value"].as_f64().unwrap() as f32);
        }
        if schema.name == "foxglove.RawImage" {
            let (w, h) = (v["width"].as_u64().unwrap(), v["height"].as_u64().unwrap());
            assert_eq!(v["encoding"], "rgb8");
            let data = base64::Engine::decode(
                &base64::engine::general_purpose::STANDARD,
                v["data"].as_str().unwrap(),
            )
            .unwrap();
            assert_eq!(data.len() as u64, w * h * 3, "{topic}");
        }
    }
    for topic in [
        "/world/image",
        "/world/attention",
        "/view/image",
        "/attention/combined",
        "/attention/weights",
        "/policy",
    ] {
        assert_eq!(counts.get(topic).copied(), Some(steps), "{topic}");
    }
    assert_eq!(counts["/mission"], 2);
    assert_eq!(schemas["/world/image"], "foxglove.RawImage");
    assert_eq!(schemas["/policy"], "groundscope.Policy");
    let word_topics = counts
        .keys()
        .filter(|t| t.starts_with("/attention/words/"))
        .count();
    assert!(word_topics >= eps[0].words().len());
    let expected: Vec<f32> = eps
        .iter()
        .flat_map(|e| e.steps.iter().map(|s| s.value))
        .collect();
    assert_eq!(values, expected);
    // Synthetic times make the messages a pure function of the episodes (the mcap crate
    // orders the summary's schema and channel records by hash, so bytes may differ there).
    let again = dir.path().join("again.mcap");
    write_mcap(&eps, &again, 0.5, None).unwrap();
    let messages = |b: &[u8]| -> Vec<(String, u64, Vec<u8>)> {
        mcap::MessageStream::new(b)
            .unwrap()
            .map(|m| {
                let m = m.unwrap();
                (m.channel.topic.clone(), m.log_time, m.data.to_vec())
            })
            .collect()
    };
    assert!(messages(&std::fs::read(&again).unwrap()) == messages(&bytes));
}

#[test]
fn faithfulness_annotations_are_recorded_beside_the_maps() {
    let mut eps = episodes("attention", 3..4);
    let ckpt = bundled::load("bundled:attention").unwrap();
    let net = groundscope::policy::Net::new(ckpt.meta.model, ckpt.params.detached()).unwrap();
    groundscope::metrics::faithfulness::annotate(&net, &mut eps[0]).unwrap();
    let steps = eps[0].steps.len();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.rrd");
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    record_rerun(&eps, &targets, 0.5, None).unwrap();
    let d = decode(&path);
    assert_eq!(
        rows(&d, "/faithfulness/occlusion", "DepthImage:buffer"),
        steps
    );
    assert_eq!(
        d.scalars["/faithfulness/interventions/uniform"].len(),
        steps
    );
    assert!(!d.scalars["/faithfulness/rank_correlation"].is_empty());
}

#[test]
fn every_bar_and_map_of_a_recording_is_named() {
    let eps = episodes("attention", 3..4);
    let ep = &eps[0];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("named.rrd");
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    record_rerun(&eps, &targets, 0.5, None).unwrap();
    let d = decode(&path);
    let steps = ep.steps.len();
    // Action bars: every row names all seven actions with their probability.
    let probs = &d.labels["/policy/probs"];
    assert_eq!(probs.len(), steps);
    for (row, step) in probs.iter().zip(&ep.steps) {
        let want: Vec<String> = [
            "left", "right", "forward", "pickup", "drop", "toggle", "done",
        ]
        .iter()
        .zip(step.probs)
        .map(|(n, p)| format!("{n} {p:.3}"))
        .collect();
        assert_eq!(row, &want);
    }
    // The bars are solid (thick line strips, rounded ends inside the bar) and as long as
    // their probability: 10 = 1, a dot of one bar height at least.
    let bars = &d.strips["/policy/probs/bars"];
    assert_eq!(bars.len(), steps);
    for (row, step) in bars.iter().zip(&ep.steps) {
        for (strip, p) in row.iter().zip(step.probs) {
            let r = 0.4;
            assert!((strip[0][0] - r).abs() < 1e-6, "{strip:?}");
            assert!(
                (strip[1][0] - (p * 10.0 - r).max(r)).abs() < 1e-4,
                "{strip:?} for p {p}"
            );
        }
    }
    // w and H bars and every map's label carry the word.
    for (k, step) in ep.steps.iter().enumerate() {
        let att = step.attention.as_ref().unwrap();
        let weights = &d.labels["/attention/weights"][k];
        let entropies = &d.labels["/attention/entropy"][k];
        assert_eq!(weights.len(), att.words.len());
        for (i, w) in att.words.iter().enumerate() {
            assert_eq!(
                weights[i],
                format!("{} · w {:.2} · H {:.2}", w.word, w.weight, w.entropy)
            );
            assert_eq!(entropies[i], format!("{} · H {:.2}", w.word, w.entropy));
            // The map's view is titled by the word: its label gives w and H.
            let label = &d.labels[&format!("/attention/words/{i}_{}/label", w.word)][k][0];
            assert!(
                label.starts_with(&format!("w {:.2} · H {:.2}", w.weight, w.entropy)),
                "{label}"
            );
        }
        let m = &d.labels["/attention/combined/label"][k][0];
        assert!(m.starts_with("M · shared scale 0–"), "{m}");
    }
    // The blueprint titles each map by its word, not by its path, and names the bar views.
    for w in ep.words() {
        assert!(
            d.view_names.contains(w),
            "no view titled {w:?}: {:?}",
            d.view_names
        );
    }
    assert!(
        !d.view_names.iter().any(|n| n.starts_with("0_")),
        "{:?}",
        d.view_names
    );
    for name in [
        "combined M",
        "action probabilities",
        "weights w",
        "entropies H (nats)",
        "grounding (this step)",
        "scale",
    ] {
        assert!(d.view_names.contains(name), "{name}: {:?}", d.view_names);
    }
    // The value-and-reward plot names its series in its title and hides its legend, which
    // would sit on the curves.
    assert!(
        d.hidden_legends.contains("value (blue) and reward (green)"),
        "{:?}",
        d.hidden_legends
    );
    assert_eq!(d.blueprints, 1, "one blueprint store, legend included");
    // Targets, trail, landmarks and the shared colour bar are there at every step.
    for entity in [
        "/world/marks/targets",
        "/attention/landmarks/walls",
        "/attention/colorbar/label",
    ] {
        assert_eq!(rows(&d, entity, "Boxes2D:half_sizes"), steps, "{entity}");
    }
    assert_eq!(rows(&d, "/world/marks/trail", "LineStrips2D:strips"), steps);
    assert_eq!(rows(&d, "/metrics/grounding", "TextDocument:text"), steps);
    assert!(d.static_entities.contains("/world/marks"));
}
