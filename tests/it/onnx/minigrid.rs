//! Your own MiniGrid agent (issue #82 item 4): rl-starter-files' `ACModel` trained briefly in
//! PyTorch on MiniGrid's own environments — image only without memory and with memory on
//! `MiniGrid-DoorKey-5x5-v0`, memory and text on `MiniGrid-Fetch-5x5-N2-v0` — exported by
//! `export/export_acmodel.py` (`export/make_fixtures.sh`). Graphs without a mission input or
//! without memory load; `eval --levels` on MiniGrid ids gives their own Python evaluation in
//! minigrid with onnxruntime (`export/eval_in_python.py`, committed as `NAME_python.csv`)
//! episode by episode; `replay`, `view --screenshot` and `faithfulness` open them; a graph
//! without maps is explained by occlusion, as on BabyAI.

use std::collections::BTreeMap;
use std::path::Path;

use crate::common::onnx_fixture as fixture;
use crate::common::{assert_bad_input, csv_rows, gs, stderr, stdout};
use groundscope::policy::onnx::OnnxAgent;
use serde_json::Value;

/// The three agents: file, the level it was trained on, whether it reads the mission and
/// whether it has memory.
const AGENTS: [(&str, &str, bool, bool); 3] = [
    (
        "acmodel_doorkey.onnx",
        "MiniGrid-DoorKey-5x5-v0",
        false,
        false,
    ),
    (
        "acmodel_doorkey_mem.onnx",
        "MiniGrid-DoorKey-5x5-v0",
        false,
        true,
    ),
    ("acmodel_fetch.onnx", "MiniGrid-Fetch-5x5-N2-v0", true, true),
];

/// The Python evaluation committed beside `graph`.
fn python_rows(graph: &str) -> Vec<BTreeMap<String, String>> {
    csv_rows(&fixture(&graph.replace(".onnx", "_python.csv")))
}

/// The sweep a Python evaluation holds: its levels in order, its seeds and episodes a seed.
fn sweep_of(rows: &[BTreeMap<String, String>]) -> (Vec<String>, usize, usize) {
    let mut levels: Vec<String> = Vec::new();
    for r in rows {
        if !levels.contains(&r["level"]) {
            levels.push(r["level"].clone());
        }
    }
    let mut seeds: Vec<&str> = rows.iter().map(|r| r["eval_seed"].as_str()).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let episodes = 1 + rows
        .iter()
        .map(|r| r["episode"].parse::<usize>().unwrap())
        .max()
        .unwrap();
    assert_eq!(rows.len(), levels.len() * seeds.len() * episodes);
    (levels, seeds.len(), episodes)
}

fn read(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn graphs_without_a_mission_or_memory_load_with_their_minigrid_level() {
    for (file, level, mission, memory) in AGENTS {
        let agent = OnnxAgent::load(&fixture(file)).unwrap();
        assert_eq!(agent.reads_mission(), mission, "{file}");
        assert_eq!(agent.has_memory(), memory, "{file}");
        assert_eq!(
            agent.meta.memory_size,
            if memory { 128 } else { 0 },
            "{file}"
        );
        assert_eq!(agent.meta.vocabulary.is_empty(), !mission, "{file}");
        assert!(!agent.has_maps(), "{file}");
        // The level names the MiniGrid id alone, without the paper's five fields.
        assert_eq!(agent.meta.level.id(), level, "{file}");
        assert!(!agent.meta.level.done_required, "{file}");
        // A step of a batch: empty memory rows without memory.
        let world = agent.meta.level.generate(3).unwrap();
        let tokens = groundscope::env::vocab::tokenize(&world.mission).unwrap();
        let m = agent.meta.memory_size;
        let obs = [world.observe(), world.observe()];
        let step = agent
            .step(
                &obs,
                &[world.agent_dir; 2],
                &[&tokens, &tokens],
                &vec![0.0; 2 * m],
                None,
            )
            .unwrap();
        assert_eq!(step.memory.len(), 2 * m, "{file}");
        let same = step.logits[0]
            .iter()
            .zip(&step.logits[1])
            .all(|(a, b)| (a - b).abs() < 1e-5);
        assert!(same, "{file}: {:?}", step.logits);
    }
}

/// The check: `groundscope eval --levels` on MiniGrid ids gives, episode by episode,
/// the graph's own Python evaluation (minigrid 3.2.0, onnxruntime): missions, actions,
/// success, steps and returns.
#[test]
fn eval_on_minigrid_ids_gives_each_agents_own_python_evaluation_episode_by_episode() {
    for (file, level, _, _) in AGENTS {
        let python = python_rows(file);
        let (levels, seeds, episodes) = sweep_of(&python);
        assert_eq!(levels[0], level, "{file}: its own level first");
        assert!(levels.len() > 1, "{file}: a sweep of levels");
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("report");
        let graph = fixture(file);
        let o = gs(&[
            "eval",
            "--checkpoint",
            graph.to_str().unwrap(),
            "--levels",
            &levels.join(","),
            "--seeds",
            &seeds.to_string(),
            "--episodes",
            &episodes.to_string(),
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        let ours = csv_rows(&out.join("episodes.csv"));
        assert_eq!(ours.len(), python.len(), "{file}");
        for (a, b) in ours.iter().zip(&python) {
            for col in [
                "level",
                "eval_seed",
                "episode",
                "level_seed",
                "mission",
                "success",
                "steps",
                "actions",
            ] {
                assert_eq!(a[col], b[col], "{file}: {col} of episode {a:?}");
            }
            let (ra, rb): (f64, f64) = (a["return"].parse().unwrap(), b["return"].parse().unwrap());
            assert!((ra - rb).abs() < 1e-6, "{file}: return {ra} vs {rb}");
        }
        let report = read(&out.join("report.json"));
        assert_eq!(report["checkpoints"][0]["variant"], "baseline", "{file}");
        let cells: Vec<&str> = report["cells"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["level"].as_str().unwrap())
            .collect();
        assert_eq!(cells, levels, "{file}");
        // Without --levels, eval runs the level the metadata names.
        let own = dir.path().join("own");
        let o = gs(&[
            "eval",
            "--checkpoint",
            graph.to_str().unwrap(),
            "--seeds",
            "1",
            "--episodes",
            "3",
            "--quiet",
            "--out",
            own.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        let rows = csv_rows(&own.join("episodes.csv"));
        assert!(rows.iter().all(|r| r["level"] == level), "{file}: {rows:?}");
        for (r, p) in rows.iter().zip(&python) {
            assert_eq!(r["actions"], p["actions"], "{file}: default level");
        }
    }
}

/// `replay` runs each agent on its level (the metadata's, or `--level`), records a trace, Rerun
/// and MCAP, and takes the Python evaluation's actions at the same level seed.
#[test]
fn replay_records_each_agent_on_its_minigrid_level() {
    for (file, level, mission, _) in AGENTS {
        let dir = tempfile::tempdir().unwrap();
        let (trace, rrd, mcap) = (
            dir.path().join("t.json"),
            dir.path().join("t.rrd"),
            dir.path().join("t.mcap"),
        );
        let graph = fixture(file);
        let o = gs(&[
            "replay",
            "--checkpoint",
            graph.to_str().unwrap(),
            "--seed",
            "3",
            "--trace",
            trace.to_str().unwrap(),
            "--save",
            rrd.to_str().unwrap(),
            "--mcap",
            mcap.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{file}: {}", stderr(&o));
        assert!(std::fs::metadata(&rrd).unwrap().len() > 1000, "{file}");
        assert!(std::fs::metadata(&mcap).unwrap().len() > 1000, "{file}");
        let t = read(&trace);
        assert_eq!(t["level"]["babyai"], level, "{file}");
        assert_eq!(t["variant"], "baseline", "{file}");
        assert!(
            t["model_name"]
                .as_str()
                .unwrap()
                .ends_with(&format!("({file})")),
            "{file}: {}",
            t["model_name"]
        );
        // The ids the graph received: only a graph that reads the mission receives any.
        assert_eq!(t.get("graph_token_ids").is_some(), mission, "{file}");
        let actions: Vec<String> = t["steps"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["action"].as_u64().unwrap().to_string())
            .collect();
        let python = python_rows(file);
        let row = python
            .iter()
            .find(|r| r["level"] == level && r["level_seed"] == "3")
            .expect("level seed 3 in the Python evaluation");
        assert_eq!(actions.join(" "), row["actions"], "{file}");
        assert_eq!(t["mission"], row["mission"].as_str(), "{file}");
        // Another MiniGrid id, named on the command line.
        let other = if mission {
            "MiniGrid-Fetch-6x6-N2-v0"
        } else {
            "MiniGrid-DoorKey-6x6-v0"
        };
        let o = gs(&[
            "replay",
            "--checkpoint",
            graph.to_str().unwrap(),
            "--level",
            other,
            "--seed",
            "1",
        ]);
        assert_eq!(o.status.code(), Some(0), "{file}: {}", stderr(&o));
        assert!(stdout(&o).contains(other), "{file}: {}", stdout(&o));
    }
}

/// A graph that reads no mission is never refused for a mission's words — on BabyAI's
/// PutNextLocal and MiniGrid's PutNear, whose words ("put", "next", "near") no DoorKey model
/// knows — while a graph that reads the mission is refused, naming the word.
#[test]
fn a_graph_that_reads_no_mission_is_not_refused_for_its_words() {
    for file in ["acmodel_doorkey.onnx", "acmodel_doorkey_mem.onnx"] {
        let graph = fixture(file);
        for level in ["BabyAI-PutNextLocal-v0", "MiniGrid-PutNear-6x6-N2-v0"] {
            let o = gs(&[
                "replay",
                "--checkpoint",
                graph.to_str().unwrap(),
                "--level",
                level,
            ]);
            assert_eq!(
                o.status.code(),
                Some(0),
                "{file} on {level}: {}",
                stderr(&o)
            );
        }
    }
    let fetch = fixture("acmodel_fetch.onnx");
    assert_bad_input(
        &gs(&[
            "replay",
            "--checkpoint",
            fetch.to_str().unwrap(),
            "--level",
            "BabyAI-PutNextLocal-v0",
        ]),
        "\"put\"",
    );
}

/// A map-less agent on a MiniGrid id gets occlusion saliency as on BabyAI: in `replay
/// --faithfulness` traces, equal to a recomputation written out here (every visible cell
/// that is not floor, not unseen and not the agent's own replaced by empty floor, one
/// forward each, from the memory of the steps before), for a graph without memory and one
/// with it; and `eval --saliency` lets it stand in for `M` in the failure classes.
#[test]
fn a_map_less_minigrid_agent_gets_occlusion_saliency_as_on_babyai() {
    for file in ["acmodel_doorkey.onnx", "acmodel_fetch.onnx"] {
        let dir = tempfile::tempdir().unwrap();
        let graph = fixture(file);
        let trace = dir.path().join("t.json");
        let o = gs(&[
            "replay",
            "--checkpoint",
            graph.to_str().unwrap(),
            "--seed",
            "4",
            "--faithfulness",
            "--trace",
            trace.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{file}: {}", stderr(&o));
        // The first steps (an episode of DoorKey may run to its 250-step limit).
        let nonzero = super::occlusion::check_trace(&graph, &read(&trace), 12, file);
        assert!(nonzero > 0, "{file}: some cell matters to the policy");
        // eval --saliency on its level: the occlusion map stands in for M.
        let eval = dir.path().join("eval");
        let o = gs(&[
            "eval",
            "--checkpoint",
            graph.to_str().unwrap(),
            "--seeds",
            "1",
            "--episodes",
            "6",
            "--saliency",
            "--quiet",
            "--out",
            eval.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{file}: {}", stderr(&o));
        let report = read(&eval.join("report.json"));
        assert_eq!(report["saliency"], true, "{file}");
        let cell = &report["cells"][0];
        let failed: u64 = cell["failure_classes"]
            .as_object()
            .unwrap()
            .values()
            .map(|v| v.as_u64().unwrap())
            .sum();
        let success = cell["success"]["mean"].as_f64().unwrap();
        assert_eq!(
            failed,
            ((1.0 - success) * 6.0).round() as u64,
            "{file}: {cell}"
        );
    }
}

/// `faithfulness` runs on each agent's level: occlusion, deletion/insertion, the closed loop on
/// the input (M cannot be set), counterfactual worlds where the level has them.
#[test]
fn faithfulness_runs_on_each_minigrid_agent() {
    for (file, level, _, _) in AGENTS {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("faith");
        let o = gs(&[
            "faithfulness",
            "--checkpoint",
            fixture(file).to_str().unwrap(),
            "--seeds",
            "1",
            "--episodes",
            "2",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{file}: {}", stderr(&o));
        let report = read(&out.join("faithfulness.json"));
        let entry = &report["checkpoints"][0];
        assert_eq!(entry["variant"], "baseline", "{file}");
        assert!(
            entry["analysed_steps"].as_u64().unwrap() > 0,
            "{file}: {entry}"
        );
        let json = std::fs::read_to_string(out.join("faithfulness.json")).unwrap();
        assert!(json.contains(level), "{file}: the report names {level}");
    }
}

/// The debugger opens each kind of agent on its MiniGrid level (a real frame under Xvfb).
#[cfg(feature = "app")]
#[test]
fn the_debugger_opens_minigrid_agents() {
    for file in ["acmodel_doorkey.onnx", "acmodel_fetch.onnx"] {
        let dir = tempfile::tempdir().unwrap();
        let shot = dir.path().join("shot.png");
        let o = std::process::Command::new("xvfb-run")
            .args(["-a", "-s", "-screen 0 1600x1000x24"])
            .arg(env!("CARGO_BIN_EXE_groundscope"))
            .args(["view", "--checkpoint"])
            .arg(fixture(file))
            .args([
                "--seed",
                "3",
                "--step",
                "2",
                "--window",
                "1200x800",
                "--screenshot",
            ])
            .arg(&shot)
            .env("RAYON_NUM_THREADS", "1")
            .env("LIBGL_ALWAYS_SOFTWARE", "1")
            .output()
            .expect("xvfb-run is needed for this test: apt-get install xvfb xauth");
        assert!(
            o.status.success(),
            "{file}: stdout: {}\nstderr: {}",
            stdout(&o),
            stderr(&o)
        );
        let img = image::open(&shot).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (1200, 800), "{file}");
    }
}
