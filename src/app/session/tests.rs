//! The session's jobs, cursor and episodes, without a window.
use std::sync::mpsc::channel;

use super::*;
use crate::env::level::LevelConfig;
use crate::episode::ActionMode;
use crate::metrics::faithfulness::episode::Loop;

fn shown(seed: u64) -> (Agent, Shown) {
    let agent = Agent::load("bundled:attention").unwrap();
    let req = EpisodeRequest::new("bundled:attention", agent.level(), seed);
    let s = run_request(&agent, &req, 0.5).unwrap();
    (agent, s)
}

fn boss_level() -> (Agent, EpisodeRequest) {
    let agent = Agent::load("bundled:babyai").unwrap();
    let id = crate::env::LevelId::parse("BabyAI-BossLevel-v0").unwrap();
    let req = EpisodeRequest::new("bundled:babyai", LevelConfig::babyai(id, false), 3);
    (agent, req)
}

/// The debugger's streamed episode: its first step is sent alone, before the rest is
/// run; the steps sent after it, appended, are the eager episode's; the whole episode
/// is the eager one.
#[test]
fn a_streamed_episode_sends_its_first_step_at_once_and_ends_as_the_eager_one() {
    let (agent, req) = boss_level();
    let (tx, rx) = channel();
    let streamed = stream_request(&agent, &req, 0.5, &tx).unwrap().unwrap();
    drop(tx);
    let mut news = rx.iter();
    let Some(JobResult::Running(first)) = news.next() else {
        panic!("the first news is the running episode")
    };
    assert_eq!((first.len(), first.is_complete()), (1, false));
    let mut grown = *first;
    for n in news {
        let JobResult::Steps(steps) = n else {
            panic!("then only steps")
        };
        assert!(!steps.is_empty());
        grown.extend(steps);
    }
    let eager = run_request(&agent, &req, 0.5).unwrap();
    assert!(eager.len() > 1000, "BossLevel seed 3 runs long");
    assert!(streamed.is_complete());
    assert_eq!(streamed.trace.to_json(), eager.trace.to_json());
    assert!(grown.len() <= eager.len());
    for (a, b) in grown.trace.steps.iter().zip(&eager.trace.steps) {
        assert_eq!((a.t, a.action, a.probs), (b.t, b.action, b.probs));
        assert_eq!(a.world.agent_pos, b.world.agent_pos);
    }
    assert_eq!(streamed.failure, eager.failure);
}

/// A newer episode drops the older one's job: its next send fails and it stops after its
/// first step instead of running to the step limit.
#[test]
fn a_stream_nobody_reads_stops() {
    let (agent, req) = boss_level();
    let (tx, rx) = channel();
    drop(rx);
    assert!(stream_request(&agent, &req, 0.5, &tx).unwrap().is_none());
}

/// Scenes come on demand, equal to those computed eagerly, and no more than
/// [`SCENES_KEPT`] are kept however many steps are looked at.
#[test]
fn scenes_are_computed_on_demand_and_a_window_of_them_is_kept() {
    let (agent, req) = boss_level();
    let shown = run_request(&agent, &req, 0.5).unwrap();
    assert_eq!(
        shown.scenes_kept(),
        0,
        "nothing drawn before it is asked for"
    );
    for i in (0..shown.len()).step_by(9) {
        let lazy = shown.scene(i).unwrap();
        assert!(shown.scenes_kept() <= SCENES_KEPT);
        if i % 270 == 0 {
            let eager = crate::record::StepScene::new(&shown.trace.steps[i], 0.5);
            assert_eq!(lazy.world, eager.world, "step {i}");
            assert_eq!(lazy.view, eager.view, "step {i}");
            assert_eq!(lazy.grounding, eager.grounding, "step {i}");
        }
    }
    assert_eq!(shown.scenes_kept(), SCENES_KEPT);
    // The step asked for again is the one kept, not recomputed.
    let again = shown.len() - 1 - (shown.len() - 1) % 9;
    let a = shown.scene(again).unwrap();
    assert!(Arc::ptr_eq(&a, &shown.scene(again).unwrap()));
    assert!(shown.scene(shown.len()).is_none());
}

#[test]
fn cursor_steps_plays_and_stops_at_the_end() {
    let mut c = Cursor::default();
    c.nudge(-1, 10);
    assert_eq!(c.step, 0);
    c.nudge(3, 10);
    assert_eq!(c.step, 3);
    c.nudge(100, 10);
    assert_eq!(c.step, 9);
    c.step = 0;
    c.playing = true;
    c.speed = 4.0;
    c.tick(0.5, 10);
    assert_eq!(c.step, 2);
    c.tick(10.0, 10);
    assert_eq!((c.step, c.playing), (9, false));
}

#[test]
fn episodes_and_probes_run_off_thread() {
    let (agent, s) = shown(3);
    let job = start_episodes(
        agent.clone(),
        Some(Agent::load("bundled:baseline").unwrap()),
        EpisodeRequest {
            mode: ActionMode::Greedy,
            ..EpisodeRequest::new("bundled:attention", agent.level(), 3)
        },
        0.5,
    );
    let JobResult::Episodes(pair) = job.wait() else {
        panic!("episodes failed")
    };
    assert_eq!(pair.0.trace.steps.len(), s.len(), "deterministic");
    assert!(pair.1.is_some());
    // Turning the agent at step 0 changes what it sees at step 0 onwards.
    let w = &s.trace.steps[0].world;
    let edit = Edit::TurnAgent((w.agent_dir + 2) % 4);
    let JobResult::Probed(p, k) = start_probe(&agent, &s, 0, &edit, 0.5).unwrap().wait() else {
        panic!("probe failed")
    };
    assert_eq!(k, 0);
    assert_eq!(p.trace.steps[0].world.agent_dir, (w.agent_dir + 2) % 4);
    // A refused edit says why, synchronously.
    let err = start_probe(&agent, &s, 0, &Edit::MoveAgent((0, 0)), 0.5).unwrap_err();
    assert!(err.contains("wall"), "{err}");
    let err = start_probe(
        &agent,
        &s,
        0,
        &Edit::Mission("go to the pink key".into()),
        0.5,
    )
    .unwrap_err();
    assert!(err.contains("pink"), "{err}");
}

#[test]
fn attention_probes_rerun_the_episode_with_m_changed_at_every_step() {
    let (agent, s) = shown(3);
    let JobResult::Probed(p, k) = start_attention_probe(&agent, &s, Loop::Uniform, 0.5).wait()
    else {
        panic!("probe failed")
    };
    assert_eq!(k, 0);
    for step in &p.trace.steps {
        let m = &step.attention.as_ref().unwrap().combined;
        assert!(m.iter().flatten().all(|v| (v - 1.0 / 49.0).abs() < 1e-6));
    }
    // With no change at all the probe is the episode itself.
    let JobResult::Probed(same, _) = start_attention_probe(&agent, &s, Loop::None, 0.5).wait()
    else {
        panic!("probe failed")
    };
    assert_eq!(same.trace.to_json(), s.trace.to_json());
}

#[test]
fn a_probe_at_step_k_keeps_the_first_k_steps() {
    let (agent, s) = shown(5);
    let k = s.len().min(3) - 1;
    let w = &s.trace.steps[k].world;
    let job = start_probe(&agent, &s, k, &Edit::TurnAgent(w.agent_dir), 0.5).unwrap();
    let JobResult::Probed(p, _) = job.wait() else {
        panic!("probe failed")
    };
    // A no-op edit reproduces the episode exactly: the memory was rebuilt faithfully.
    assert_eq!(p.len(), s.len());
    for (a, b) in p.trace.steps.iter().zip(&s.trace.steps) {
        assert_eq!((a.action, a.probs), (b.action, b.probs));
    }
}

#[test]
fn exports_write_files_off_thread() {
    let (_, s) = shown(3);
    let dir = tempfile::tempdir().unwrap();
    for export in [
        Export::Rrd(dir.path().join("e.rrd")),
        Export::Mcap(dir.path().join("e.mcap")),
        Export::Gif(dir.path().join("e.gif")),
    ] {
        let job = start_export(&s, export.clone(), 0.5, Arc::new(AtomicBool::new(false)));
        match job.wait() {
            JobResult::Exported(m) => assert!(m.starts_with("wrote"), "{m}"),
            other => panic!("{export:?}: {other:?}"),
        }
    }
    let gif = image::open(dir.path().join("e.gif")).unwrap();
    assert!(gif.width() > 0);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 3);
}

#[test]
fn a_job_that_panics_fails_instead_of_running_for_ever() {
    let job = Job::spawn("exploding".into(), 0, |_| panic!("boom"));
    let deadline = std::time::Instant::now() + std::time::Duration::from_mins(1);
    let result = loop {
        if let Some(r) = job.poll() {
            break r;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the job never finished"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    match result {
        JobResult::Failed(e) => assert!(e.contains("exploding failed: boom"), "{e}"),
        _ => panic!("a panicking job must fail"),
    }
}

#[test]
fn next_miss_and_failure_step_find_their_steps() {
    let (_, s) = shown(3);
    if let Some(i) = next_miss(&s, 0) {
        assert!(
            s.scene(i)
                .unwrap()
                .grounding
                .iter()
                .any(|g| g.hits.iter().any(|h| !h.acc_cmb))
        );
    }
    match failure_step(&s.trace) {
        Some(i) => assert_eq!(i, s.len() - 1),
        None => assert!(s.trace.success()),
    }
}
