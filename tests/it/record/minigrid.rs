//! Recordings of MiniGrid's own environments: Dynamic-Obstacles' balls drawn where the env has
//! them at every step, an agent of three actions recorded with three bars (`.rrd`, MCAP, the
//! JSON trace) even where it knows its width only once it has answered, and the objects "key", "ball", "goal" and "lava" name circled on the world
//! under their maps, on small and big worlds alike.

use crate::common::rrd::{decode, rows};
use crate::common::worlds::babyai;
use groundscope::env::{Color, LevelConfig, ObjectKind, Pos, World};
use groundscope::episode::{
    ActionMode, EpisodeSpec, EpisodeTrace, initial_world, run_episode, run_from,
};
use groundscope::metrics::grounding::WordKind;
use groundscope::policy::acting::{flat_memory_rows, softmax};
use groundscope::policy::{ActOutput, Acting, Memory, MissionInputs, PolicyError, Step, Variant};
use groundscope::record::scene::{StepScene, TILE_PX, referent_marks, world_picture};
use groundscope::record::{RerunTargets, record_rerun, write_mcap};
use groundscope::render::{palette, px_in_image, visible_cells};

/// A policy of three actions (left, right, forward), as a graph trained on Dynamic-Obstacles'
/// action space outputs: the same logits at every step.
struct ThreeActions([f32; 3]);

impl Acting for ThreeActions {
    fn variant(&self) -> Variant {
        Variant::Baseline
    }

    fn zero_memory(&self) -> Result<Memory, PolicyError> {
        flat_memory_rows(Vec::new(), 1)
    }

    fn prepare(&self, _tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError> {
        Ok(None)
    }

    fn act_step(&self, step: &Step<'_>) -> Result<ActOutput, PolicyError> {
        let b = step.obs.len();
        let logits = vec![self.0.to_vec(); b];
        Ok(ActOutput {
            probs: logits.iter().map(|l| softmax(l)).collect(),
            logits,
            values: vec![0.0; b],
            memory: flat_memory_rows(Vec::new(), b)?,
            traces: None,
        })
    }

    fn zero_memory_batch(&self, batch: usize) -> Result<Memory, PolicyError> {
        flat_memory_rows(Vec::new(), batch)
    }

    fn prepare_batch(&self, _missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError> {
        Ok(None)
    }

    fn takes_interventions(&self) -> bool {
        false
    }

    fn n_actions(&self) -> usize {
        3
    }
}

fn spec(level: LevelConfig, seed: u64) -> EpisodeSpec {
    EpisodeSpec {
        level,
        seed,
        mission: None,
        mode: ActionMode::Greedy,
    }
}

/// The greedy episode of `policy` on `level` at `seed`.
fn run(policy: &dyn Acting, level: LevelConfig, seed: u64) -> EpisodeTrace {
    let spec = spec(level, seed);
    run_from(
        policy,
        "three actions",
        &spec,
        initial_world(&spec).unwrap(),
    )
    .unwrap()
}

/// The cells of the balls, in order.
fn balls(w: &World) -> Vec<Pos> {
    let mut out: Vec<Pos> = w
        .grid
        .objects()
        .filter(|(_, o)| o.kind == ObjectKind::Ball)
        .map(|(p, _)| p)
        .collect();
    out.sort_unstable();
    out
}

/// Each step's picture shows the balls where the env, stepped on its own with the same
/// actions, has them before that step's action: the trace keeps the world of every step, so a
/// ball that moves is drawn moving, step by step; the `.rrd` holds one world picture a step.
#[test]
fn moving_obstacles_are_drawn_where_the_env_has_them_at_every_step() {
    let level = babyai("MiniGrid-Dynamic-Obstacles-8x8-v0");
    // Turning left in place: never walks into a ball, so the episode runs to its limit.
    let ep = run(&ThreeActions([2.0, 0.0, 0.0]), level, 0);
    let mut env = level.generate(0).unwrap();
    let blue = palette::object(Color::Blue);
    let (mut moved, mut drawn) = (0, 0);
    for (k, step) in ep.steps.iter().enumerate() {
        assert_eq!(balls(&step.world), balls(&env), "step {k}");
        if k > 0 && balls(&step.world) != balls(&ep.steps[k - 1].world) {
            moved += 1;
        }
        // The pictures of the first 40 steps will do: the positions are checked at every step.
        if k < 40 {
            let scene = StepScene::new(step, 0.5);
            for p in balls(&env) {
                let (x, y) = px_in_image(p, TILE_PX);
                let got = scene.world.get_pixel(x + TILE_PX / 2, y + TILE_PX / 2).0;
                assert!(
                    got == blue || got == palette::highlight(blue),
                    "step {k}: the ball at {p:?} is drawn {got:?}"
                );
                drawn += 1;
            }
        }
        env.step(step.action).unwrap();
    }
    assert!(ep.steps.len() > 100, "{} steps", ep.steps.len());
    assert!(
        moved * 2 > ep.steps.len(),
        "the balls moved at {moved} steps"
    );
    assert!(drawn >= 40 * 4, "{drawn} balls drawn");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dynamic.rrd");
    let mut short = ep.clone();
    short.steps.truncate(20);
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    record_rerun(std::slice::from_ref(&short), &targets, 0.5, None).unwrap();
    assert_eq!(rows(&decode(&path), "/world/grid", "Image:buffer"), 20);
}

/// An agent of three actions gets three bars, never seven with four empty ones: in the
/// `.rrd` (each row's labels, the chart's frame and its view's bounds), in MCAP's `/policy`
/// and in the JSON trace.
#[test]
fn an_agent_of_three_actions_is_recorded_with_three_bars() {
    let level = babyai("MiniGrid-Dynamic-Obstacles-8x8-v0");
    let mut ep = run(&ThreeActions([0.0, 0.5, 2.0]), level, 1);
    assert_eq!(ep.n_actions, 3);
    ep.steps.truncate(12);
    let steps = ep.steps.len();
    assert!(steps > 0);
    for s in &ep.steps {
        assert_eq!(s.action.name(), "forward", "greedy on the largest logit");
        assert_eq!(s.probs[3..], [0.0; 4], "{:?}", s.probs);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("three.rrd");
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    record_rerun(std::slice::from_ref(&ep), &targets, 0.5, None).unwrap();
    let d = decode(&path);
    let labels = &d.labels["/policy/probs"];
    assert_eq!(labels.len(), steps);
    for (row, step) in labels.iter().zip(&ep.steps) {
        let want: Vec<String> = ["left", "right", "forward"]
            .iter()
            .zip(step.probs)
            .map(|(n, p)| format!("{n} {p:.3}"))
            .collect();
        assert_eq!(row, &want);
    }
    let frame = d.boxes["/policy/probs/frame"][0][0];
    let chart = d.view_bounds["action probabilities"];
    // Three rows of 3 units each: the frame and the view hold three bars, not seven.
    assert!((frame[3] - frame[1] - 9.0).abs() < 1e-4, "{frame:?}");
    assert!(chart[3] - chart[2] < 10.0, "{chart:?}");
    let mcap = dir.path().join("three.mcap");
    write_mcap(std::slice::from_ref(&ep), &mcap, 0.5, None).unwrap();
    let bytes = std::fs::read(&mcap).unwrap();
    let mut policies = 0;
    for msg in mcap::MessageStream::new(&bytes).unwrap() {
        let msg = msg.unwrap();
        if msg.channel.topic != "/policy" {
            continue;
        }
        let v: serde_json::Value = serde_json::from_slice(&msg.data).unwrap();
        let mut keys: Vec<&str> = v["probs"]
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        keys.sort_unstable();
        assert_eq!(keys, ["forward", "left", "right"], "{v}");
        policies += 1;
    }
    assert_eq!(policies, steps);
    let json: serde_json::Value = serde_json::from_str(&ep.to_json()).unwrap();
    for s in json["steps"].as_array().unwrap() {
        assert_eq!(s["probs"].as_array().unwrap().len(), 3);
    }
}

/// [`ThreeActions`] that says it scores 7 until its first step, as a Python callable does (it
/// learns its width from the logits it gets back).
struct LearnsWidth(ThreeActions, std::cell::Cell<bool>);

impl Acting for LearnsWidth {
    fn variant(&self) -> Variant {
        self.0.variant()
    }

    fn zero_memory(&self) -> Result<Memory, PolicyError> {
        self.0.zero_memory()
    }

    fn prepare(&self, tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError> {
        self.0.prepare(tokens)
    }

    fn act_step(&self, step: &Step<'_>) -> Result<ActOutput, PolicyError> {
        self.1.set(true);
        self.0.act_step(step)
    }

    fn zero_memory_batch(&self, batch: usize) -> Result<Memory, PolicyError> {
        self.0.zero_memory_batch(batch)
    }

    fn prepare_batch(&self, missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError> {
        self.0.prepare_batch(missions)
    }

    fn takes_interventions(&self) -> bool {
        false
    }

    fn n_actions(&self) -> usize {
        if self.1.get() { 3 } else { 7 }
    }
}

/// A policy whose width is known only once it has answered (a Python callable's) is traced
/// with that width from the first step: three probabilities shown, and its sampled actions
/// drawn among the three it scores.
#[test]
fn a_width_learned_at_the_first_step_is_the_traces() {
    let level = babyai("MiniGrid-Dynamic-Obstacles-8x8-v0");
    for seed in 0..4 {
        let policy = LearnsWidth(ThreeActions([0.0, 0.0, 0.0]), std::cell::Cell::new(false));
        let spec = EpisodeSpec {
            mode: ActionMode::Sampled,
            ..spec(level, seed)
        };
        let ep = run_from(&policy, "learns", &spec, initial_world(&spec).unwrap()).unwrap();
        assert_eq!(ep.n_actions, 3, "seed {seed}");
        assert!(!ep.steps.is_empty());
        for s in &ep.steps {
            assert!((s.action as usize) < 3, "seed {seed}: {:?}", s.action);
            assert_eq!(ep.action_probs(s).len(), 3);
        }
    }
}

/// An untrained attention model of every word, greedy on `id` at `seed`.
fn attention_episode(id: &str, seed: u64) -> EpisodeTrace {
    let level = babyai(id);
    let ckpt = crate::common::fresh_attention(level);
    run_episode(&ckpt, "fresh", &spec(level, seed)).unwrap()
}

/// Whether `kind` word `word` names an object of `o`'s kind.
fn named_by(word: &str, kind: WordKind, o: ObjectKind) -> bool {
    match kind {
        WordKind::Goal => o == ObjectKind::Goal,
        WordKind::Lava => o == ObjectKind::Lava,
        WordKind::Object => o.name() == word,
        _ => true,
    }
}

/// Under the map of "key" on DoorKey-8x8, "lava" on LavaCrossingS11N5, "ball" on
/// ObstructedMaze (1Dlhb's blocking ball is in view at once; Full's balls only once a door
/// is passed, which a fresh network may never do) and "goal" wherever the goal comes into view (MultiRoom-N6 too), the
/// world picture circles exactly the visible cells the word names, each in its grounding
/// colour, and nothing else of that kind.
#[test]
fn the_cells_goal_lava_and_key_name_are_circled_under_their_maps() {
    let mut circled: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
    for (id, word) in [
        ("MiniGrid-DoorKey-8x8-v0", "key"),
        ("MiniGrid-LavaCrossingS11N5-v0", "lava"),
        ("MiniGrid-ObstructedMaze-Full-v0", "ball"),
        ("MiniGrid-ObstructedMaze-1Dlhb-v0", "ball"),
        ("MiniGrid-MultiRoom-N6-v0", "goal"),
    ] {
        // Until the word's cells came into view (MultiRoom's goal may never within its
        // first steps: it is in the last room).
        for seed in 0..8 {
            if circled.get(id).is_some_and(|n| *n > 0) {
                break;
            }
            let ep = attention_episode(id, seed);
            // ObstructedMaze-Full's balls are behind its doors' blockers, seen later.
            let steps = if id.contains("ObstructedMaze") {
                400
            } else {
                30
            };
            for step in ep.steps.iter().take(steps) {
                let scene = StepScene::new(step, 0.5);
                let att = step.attention.as_ref().unwrap();
                for g in &scene.grounding {
                    let Some(i) = g.word else { continue };
                    let marks = referent_marks(&step.world, Some(g));
                    let seen = visible_cells(&step.world);
                    for &(p, _) in &marks {
                        assert!(seen.contains(&p), "{id}: {p:?} is in view");
                        // An opening is a free cell: nothing to name there.
                        let Some(o) = step.world.grid.get(p) else {
                            assert_eq!(g.kind, WordKind::Opening, "{id} {p:?}");
                            continue;
                        };
                        assert!(
                            named_by(&att.words[i].word, g.kind, o.kind),
                            "{id}: {} names {}",
                            att.words[i].word,
                            o.describe()
                        );
                    }
                    if att.words[i].word != word {
                        continue;
                    }
                    let img = world_picture(
                        step,
                        &scene.world,
                        Some(&att.words[i].map),
                        scene.scale_max,
                        &[],
                        &marks,
                    );
                    for &(p, color) in &marks {
                        // The ring's left edge, half way down the cell.
                        let (x, y) = px_in_image(p, TILE_PX);
                        assert_eq!(img.get_pixel(x + 1, y + TILE_PX / 2).0, color, "{id} {p:?}");
                    }
                    *circled.entry(id).or_insert(0) += marks.len();
                }
            }
        }
    }
    for id in [
        "MiniGrid-DoorKey-8x8-v0",
        "MiniGrid-LavaCrossingS11N5-v0",
        "MiniGrid-ObstructedMaze-1Dlhb-v0",
    ] {
        assert!(circled.get(id).is_some_and(|n| *n > 0), "{id}: {circled:?}");
    }
}
