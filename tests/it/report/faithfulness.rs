//! Faithfulness: interventions that change nothing reproduce the episode, no-op
//! counterfactuals reproduce the trace, occlusion is zero where nothing is replaced, the
//! command writes a complete report or none, and `replay --faithfulness` annotates traces and
//! recordings.

use crate::common::{self, assert_bad_input, gs};
use candle_core::{Device, Tensor};
use groundscope::env::edit::{Edit, apply};
use groundscope::episode::{ActionMode, EpisodeSpec, initial_world, run_episode, run_from};
use groundscope::metrics::faithfulness::annotate;
use groundscope::metrics::faithfulness::step::{StepInput, analyse, cell_index, occludable};
use groundscope::policy::{ActOptions, Intervention, Memory, Net, act, bundled};
use rand::SeedableRng as _;

fn attention_net() -> (groundscope::policy::Checkpoint, Net) {
    let ckpt = bundled::load("bundled:attention").unwrap();
    let net = Net::new(ckpt.meta.model, ckpt.params.detached()).unwrap();
    (ckpt, net)
}

fn spec(level: groundscope::env::LevelConfig, seed: u64) -> EpisodeSpec {
    EpisodeSpec {
        level,
        seed,
        mission: None,
        mode: ActionMode::Greedy,
    }
}

#[test]
fn identity_interventions_reproduce_the_step() {
    let (ckpt, net) = attention_net();
    let world = ckpt.meta.level.generate(7).unwrap();
    let tokens = groundscope::env::vocab::tokenize(&world.mission).unwrap();
    let obs = world.observe();
    let mem = Memory::zeros(1, net.cfg.lstm_hidden).unwrap();
    // One traced step, under an intervention or none.
    let step = |intervention: Option<&Intervention>| {
        let opts = ActOptions {
            traces: true,
            intervention,
            ..ActOptions::default()
        };
        act(&net, &[obs], &[&tokens], &mem, opts).unwrap()
    };
    let base = step(None);
    let m: Vec<f32> = base.traces.as_ref().unwrap()[0]
        .combined
        .iter()
        .flatten()
        .copied()
        .collect();
    // M set to itself: bit for bit the same step.
    let same = Intervention::SetM(Tensor::from_vec(m, (1, 49), &Device::Cpu).unwrap());
    let out = step(Some(&same));
    assert_eq!(out.probs, base.probs);
    assert_eq!(out.values, base.values);
    // Every word weight scaled by 1: the same up to the renormalisation's rounding.
    let ones = Intervention::ScaleWeights(
        Tensor::ones((1, tokens.len()), candle_core::DType::F32, &Device::Cpu).unwrap(),
    );
    let out = step(Some(&ones));
    for (a, b) in out.probs[0].iter().zip(&base.probs[0]) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
    // A weight set to 0: the others are renormalised to sum to 1 — or, when no other word
    // counts (a model whose only attending words are the content words, a mission naming one),
    // every weight is 0 and so is M.
    let mut f = vec![1f32; tokens.len()];
    f[tokens.len() - 1] = 0.0;
    let zero =
        Intervention::ScaleWeights(Tensor::from_vec(f, (1, tokens.len()), &Device::Cpu).unwrap());
    let out = step(Some(&zero));
    let trace = &out.traces.unwrap()[0];
    let w = &trace.words;
    assert_eq!(w.last().unwrap().weight, 0.0);
    let base_words = &base.traces.as_ref().unwrap()[0].words;
    let others: f32 = base_words[..tokens.len() - 1]
        .iter()
        .map(|x| x.weight)
        .sum();
    let total: f32 = w.iter().map(|x| x.weight).sum();
    if others > 0.0 {
        assert!((total - 1.0).abs() < 1e-5, "{total}");
    } else {
        assert_eq!(total, 0.0);
        assert!(trace.combined.iter().flatten().all(|x| *x == 0.0));
    }
}

#[test]
fn a_no_op_counterfactual_reproduces_the_trace_exactly() {
    let (ckpt, net) = attention_net();
    for seed in [2, 5, 11] {
        let s = spec(ckpt.meta.level, seed);
        let original = run_episode(&ckpt, "bundled:attention", &s).unwrap();
        let world = initial_world(&s).unwrap();
        let target = world.target_positions()[0];
        let color = world.grid.get(target).unwrap().color;
        let edited = apply(&world, &Edit::Recolor(target, color)).unwrap();
        let again = run_from(&net, "bundled:attention", &s, edited).unwrap();
        assert_eq!(again.to_json(), original.to_json(), "seed {seed}");
    }
}

#[test]
fn occlusion_is_zero_where_nothing_is_replaced_and_annotation_is_deterministic() {
    let (ckpt, net) = attention_net();
    let mut trace = run_episode(&ckpt, "bundled:attention", &spec(ckpt.meta.level, 4)).unwrap();
    let step = &trace.steps[0];
    let mem = Memory::zeros(1, net.cfg.lstm_hidden).unwrap();
    let input = StepInput {
        agent: &net,
        direction: step.world.agent_dir,
        tokens: &trace.tokens,
        memory: &mem,
        obs: step.obs,
        words: groundscope::env::targets::word_targets(&step.world, &step.obs, trace.tokens.len()),
        targets: groundscope::metrics::grounding::pending_targets(&step.world, &step.obs),
        probs: &step.probs,
        action: step.action as usize,
        attention: step.attention.as_ref(),
    };
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(1);
    let r = analyse(&input, &mut rng).unwrap();
    let replaced: Vec<usize> = occludable(&step.obs).into_iter().map(cell_index).collect();
    assert!(!replaced.is_empty());
    for (j, d) in r.occlusion.iter().enumerate() {
        assert!((0.0..=1.0).contains(d), "Δ is a total-variation distance");
        if !replaced.contains(&j) {
            assert_eq!(*d, 0.0, "cell {j} was not replaced");
        }
    }
    assert!(r.occlusion.iter().any(|d| *d > 0.0));
    annotate(&net, &mut trace).unwrap();
    let first = trace.to_json();
    annotate(&net, &mut trace).unwrap();
    assert_eq!(trace.to_json(), first);
    let f = trace.steps[0].faithfulness.as_ref().unwrap();
    let flat: Vec<f64> = f
        .occlusion
        .iter()
        .flatten()
        .map(|x| f64::from(*x))
        .collect();
    // The annotation of step 0 (zero memory) is the analysis above.
    for (a, b) in flat.iter().zip(&r.occlusion) {
        assert!((a - b).abs() < 1e-6);
    }
    assert!(f.interventions.contains_key("uniform") && f.interventions.contains_key("permuted"));
}

#[test]
fn the_command_writes_a_complete_report_with_controls() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("f");
    let o = gs(&[
        "faithfulness",
        "--seeds",
        "2",
        "--episodes",
        "3",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "deletion.png",
            "effects.png",
            "faithfulness.json",
            "faithfulness.md",
            "faithfulness_steps.csv",
            "rank_correlation.png"
        ]
    );
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("faithfulness.json")).unwrap()).unwrap();
    assert_eq!(j["schema_version"], 1);
    let c = &j["checkpoints"][0];
    assert_eq!(c["episodes"], 6);
    for key in ["rank_correlation", "argmax_agreement", "object_agreement"] {
        let p = &c["occlusion"][key];
        assert!(p["value"]["mean"].is_number(), "{key}: {p}");
        assert!(p["control"]["mean"].is_number(), "{key} has its control");
    }
    for kind in ["object", "combined"] {
        let l = &c["localisation"][kind]["pointing_game"];
        assert!(l["value"]["mean"].as_f64().unwrap() > l["control"]["mean"].as_f64().unwrap());
    }
    assert!(c["closed_loop"]["uniform"]["success"]["mean"].is_number());
    assert!(c["deletion"]["random"]["mean"].is_number());
    let csv = std::fs::read_to_string(out.join("faithfulness_steps.csv")).unwrap();
    assert_eq!(
        csv.lines().count() - 1,
        c["analysed_steps"].as_u64().unwrap() as usize
    );
    // faithfulness.md opens with its verdict in a sentence, from its own closed loops.
    let md = std::fs::read_to_string(out.join("faithfulness.md")).unwrap();
    let verdict = md.lines().nth(2).unwrap();
    assert!(verdict.starts_with("**Verdict** (`"), "{md}");
    let none = &c["closed_loop"]["none"]["success"]["mean"];
    let unmodified = format!("(unmodified {:.3})", none.as_f64().unwrap());
    assert!(
        (verdict.contains("`M` is causal here:")
            || verdict.contains("`M` is not shown to be causal here:"))
            && verdict.contains(&unmodified),
        "{verdict}"
    );
    // `--episodes` is per seed: the report says what they add up to (2 × 3 = 6 above), and
    // so does the help.
    assert!(
        md.contains("2 seeds × 3 episodes per seed = 6 episodes per checkpoint and level"),
        "{md}"
    );
    let help = gs(&["faithfulness", "--help"]);
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.contains("--seeds × --episodes episodes"), "{help}");
    // Every figure written is linked in faithfulness.md.
    for f in names.iter().filter(|n| {
        std::path::Path::new(n)
            .extension()
            .is_some_and(|e| e == "png")
    }) {
        assert!(md.contains(&format!("]({f})")), "{f} not linked:\n{md}");
    }
}

#[test]
fn baselines_get_occlusion_and_input_loops_and_bad_outputs_leave_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("b");
    let o = gs(&[
        "faithfulness",
        "--checkpoint",
        "bundled:baseline",
        "--episodes",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_bad_input(&o, "--episodes");
    assert!(!out.exists());
    let o = gs(&[
        "faithfulness",
        "--checkpoint",
        "bundled:baseline",
        "--seeds",
        "1",
        "--episodes",
        "2",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("faithfulness.json")).unwrap()).unwrap();
    let c = &j["checkpoints"][0];
    assert!(c["occlusion"]["rank_correlation"].is_null());
    assert!(c["occlusion"]["target_most_effective"]["value"]["mean"].is_number());
    // Without M its closed loop occludes the input: the most salient object, or a random one.
    let loops: Vec<&String> = c["closed_loop"].as_object().unwrap().keys().collect();
    assert_eq!(loops, ["none", "occlude_random", "occlude_salient"]);
    for name in loops {
        assert!(
            c["closed_loop"][name]["success"]["mean"].is_number(),
            "{name}: {c}"
        );
    }
    // A directory that cannot be written: one line, exit 2, nothing behind.
    let file = tmp.path().join("plain");
    std::fs::write(&file, b"x").unwrap();
    let o = gs(&[
        "faithfulness",
        "--seeds",
        "1",
        "--episodes",
        "1",
        "--out",
        file.join("sub").to_str().unwrap(),
    ]);
    assert_bad_input(&o, "plain");
    let o = gs(&["faithfulness", "--out", file.to_str().unwrap()]);
    assert_bad_input(&o, "not a directory");
    assert_eq!(std::fs::read(&file).unwrap(), b"x");
}

#[test]
fn replay_adds_faithfulness_to_the_trace_and_the_recordings() {
    let tmp = tempfile::tempdir().unwrap();
    let trace = tmp.path().join("t.json");
    let mcap = tmp.path().join("t.mcap");
    let o = gs(&[
        "replay",
        "--seed",
        "3",
        "--faithfulness",
        "--trace",
        trace.to_str().unwrap(),
        "--mcap",
        mcap.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&trace).unwrap()).unwrap();
    for s in j["steps"].as_array().unwrap() {
        let f = &s["faithfulness"];
        assert_eq!(f["occlusion"].as_array().unwrap().len(), 7);
        assert!(f["interventions"]["uniform"]["tv"].is_number());
    }
    let bytes = std::fs::read(&mcap).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let topics: Vec<&str> = summary
        .channels
        .values()
        .map(|c| c.topic.as_str())
        .collect();
    assert!(topics.contains(&"/faithfulness") && topics.contains(&"/faithfulness/occlusion"));
    // Without the flag the trace has no such field.
    let plain = tmp.path().join("p.json");
    gs(&["replay", "--seed", "3", "--trace", plain.to_str().unwrap()]);
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&plain).unwrap()).unwrap();
    assert!(j["steps"][0].get("faithfulness").is_none());
}

/// On a level whose targets are doors (GoToDoor) the door word's map is localised on the
/// doors, the steps with a door in view are analysed (occlusion ranks doors), and steering `M`
/// moves it to another door, whose reaching counts as a distractor (issue #64; all three
/// measured nothing there before).
#[test]
fn door_targets_are_localised_ranked_and_steered_to() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f");
    let o = gs(&[
        "faithfulness",
        "--checkpoint",
        "bundled:babyai",
        "--levels",
        "BabyAI-GoToDoor-v0",
        "--seeds",
        "1",
        "--episodes",
        "4",
        "--first-seed",
        "1400",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let md = std::fs::read_to_string(out.join("faithfulness.md")).unwrap();
    let value = |row: &str| {
        let line = md
            .lines()
            .find(|l| l.starts_with(&format!("| {row}")))
            .unwrap_or_else(|| panic!("no row {row}:\n{md}"));
        line.split('|').nth(2).unwrap().trim().to_owned()
    };
    for row in [
        "door map: pointing game",
        "occlusion: the target is the top-Δ object",
        "closed loop, steered: success / distractor",
    ] {
        let v = value(row);
        assert!(!v.starts_with('–'), "{row}: {v}");
    }
    // Steering sends the bundled agent to another door in some episode.
    let steered = value("closed loop, steered: success / distractor");
    let distractor: f64 = steered
        .split('/')
        .nth(1)
        .unwrap()
        .split('±')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!(distractor > 0.0, "{steered}");
}
