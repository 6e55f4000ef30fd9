//! The debugger's model, free of any UI: which checkpoints and episode are loaded, the step
//! cursor and playback, and the jobs that run off the UI thread (episodes, probes, exports).
//! Everything here is testable without a display.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, channel};

use crate::env::edit::{Edit, apply};
use crate::env::level::LevelConfig;
use crate::episode::{ActionMode, EpisodeSpec, EpisodeTrace, rerun_from, run_from, run_from_with};
use crate::metrics::failure::{Diagnosis, Evidence};
use crate::metrics::faithfulness::episode::{Loop, intervention};
use crate::panics::panic_line;
use crate::policy::Acting;
use crate::record::{RerunTargets, StepScene, episode_scenes, record_rerun, write_mcap};

/// A loaded policy, ready to act: a native checkpoint or an imported ONNX graph.
#[derive(Clone, Debug)]
pub struct Agent {
    /// What the user chose: `bundled:attention`, `bundled:baseline`, a checkpoint path or a
    /// `.onnx` file.
    pub spec: String,
    /// The policy, shared with the jobs that run it.
    pub policy: Arc<crate::policy::Agent>,
}

impl Agent {
    /// Loads `spec` ([`crate::policy::Agent::load`]).
    pub fn load(spec: &str) -> Result<Self, String> {
        let policy = crate::policy::Agent::load(spec).map_err(|e| e.to_string())?;
        Ok(Self {
            spec: spec.to_owned(),
            policy: Arc::new(policy),
        })
    }

    /// The level it was trained on.
    pub fn level(&self) -> LevelConfig {
        self.policy.level()
    }

    /// The policy, to run episodes with.
    pub fn acting(&self) -> &(dyn Acting + Send + Sync) {
        self.policy.acting()
    }
}

/// An episode with its per-step scenes.
#[derive(Clone, Debug)]
pub struct Shown {
    /// The trace.
    pub trace: Arc<EpisodeTrace>,
    /// One scene per step.
    pub scenes: Arc<Vec<StepScene>>,
    /// Why the episode failed, as `eval` classifies it (`None` for a success).
    pub failure: Option<Diagnosis>,
}

impl Shown {
    fn new(trace: EpisodeTrace, alpha: f64) -> Self {
        let scenes = episode_scenes(&trace, alpha);
        let failure = Evidence::from_trace(&trace).diagnose();
        Self {
            trace: Arc::new(trace),
            scenes: Arc::new(scenes),
            failure,
        }
    }

    /// Steps in the episode.
    pub fn len(&self) -> usize {
        self.trace.steps.len()
    }

    /// Whether the episode has no step.
    pub fn is_empty(&self) -> bool {
        self.trace.steps.is_empty()
    }
}

/// The result of a background job.
#[derive(Debug)]
pub enum JobResult {
    /// Fresh episodes: the main one and, in compare mode, the second checkpoint's.
    Episodes(Box<(Shown, Option<Shown>)>),
    /// A probe: the main episode re-run from an edited state.
    Probed(Box<Shown>, usize),
    /// A file was written or a stream sent.
    Exported(String),
    /// Something failed; the message is shown in the UI.
    Failed(String),
}

/// A job running on another thread.
#[derive(Debug)]
pub struct Job {
    /// What it does, for the status line.
    pub what: String,
    /// Steps done so far (exports), for the progress bar.
    pub done: Arc<AtomicUsize>,
    /// Steps in all.
    pub total: usize,
    rx: Receiver<JobResult>,
}

impl Job {
    fn spawn(
        what: String,
        total: usize,
        work: impl FnOnce(&AtomicUsize) -> JobResult + Send + 'static,
    ) -> Self {
        let (tx, rx) = channel();
        let done = Arc::new(AtomicUsize::new(0));
        let d = done.clone();
        let label = what.clone();
        std::thread::spawn(move || {
            // A panic is the job's error, shown in the window (and the end of a headless
            // screenshot), not a job the window waits on for ever.
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&d)))
                .unwrap_or_else(|p| {
                    JobResult::Failed(format!("{label} failed: {}", panic_line(p.as_ref())))
                });
            let _ = tx.send(result);
        });
        Self {
            what,
            done,
            total,
            rx,
        }
    }

    /// The result, once the job has finished.
    pub fn poll(&self) -> Option<JobResult> {
        match self.rx.try_recv() {
            Ok(r) => Some(r),
            Err(std::sync::mpsc::TryRecvError::Empty) => None,
            // The thread ended without an answer: finished, as a failure.
            Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                Some(JobResult::Failed(format!("{} stopped", self.what)))
            }
        }
    }

    /// Blocks until the job has finished (tests and the headless screenshot).
    pub fn wait(self) -> JobResult {
        self.rx
            .recv()
            .unwrap_or_else(|_| JobResult::Failed(format!("{} stopped", self.what)))
    }
}

/// What to export.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Export {
    /// A Rerun recording.
    Rrd(PathBuf),
    /// MCAP.
    Mcap(PathBuf),
    /// An animated GIF of the world with `M` overlaid.
    Gif(PathBuf),
    /// Stream to a spawned viewer.
    Spawn,
    /// Stream to a running viewer at this URL.
    Connect(String),
}

/// The episode request the controls describe.
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// Level.
    pub level: LevelConfig,
    /// Seed.
    pub seed: u64,
    /// Greedy or sampled.
    pub mode: ActionMode,
    /// Mission override.
    pub mission: Option<String>,
}

/// Runs `agent` on `req`.
pub fn run_request(agent: &Agent, req: &Request, alpha: f64) -> Result<Shown, String> {
    let spec = EpisodeSpec {
        level: req.level,
        seed: req.seed,
        mission: req.mission.clone(),
        mode: req.mode,
    };
    let world = crate::episode::initial_world(&spec).map_err(|e| e.to_string())?;
    let trace = run_from(agent.acting(), &agent.spec, &spec, world).map_err(|e| e.to_string())?;
    Ok(Shown::new(trace, alpha))
}

/// Starts running the main (and compared) agent on `req`.
pub fn start_episodes(main: Agent, compare: Option<Agent>, req: Request, alpha: f64) -> Job {
    Job::spawn(format!("running seed {}", req.seed), 0, move |_| {
        let a = match run_request(&main, &req, alpha) {
            Ok(a) => a,
            Err(e) => return JobResult::Failed(e),
        };
        let b = match compare
            .as_ref()
            .map(|c| run_request(c, &req, alpha))
            .transpose()
        {
            Ok(b) => b,
            Err(e) => return JobResult::Failed(format!("compared checkpoint: {e}")),
        };
        JobResult::Episodes(Box::new((a, b)))
    })
}

/// Applies `edit` to the world at step `k` of `shown` and starts re-running the agent from
/// there. A refused edit is returned at once, with the reason.
pub fn start_probe(
    agent: &Agent,
    shown: &Shown,
    k: usize,
    edit: &Edit,
    alpha: f64,
) -> Result<Job, String> {
    let step = shown
        .trace
        .steps
        .get(k)
        .ok_or_else(|| format!("step {k} is past the end of the episode"))?;
    let world = apply(&step.world, edit).map_err(|e| e.to_string())?;
    let agent = agent.clone();
    let trace = shown.trace.clone();
    Ok(Job::spawn(
        format!("probing step {k}"),
        0,
        move |_| match rerun_from(agent.acting(), &trace, k, world) {
            Ok(t) => JobResult::Probed(Box::new(Shown::new(t, alpha)), k),
            Err(e) => JobResult::Failed(e.to_string()),
        },
    ))
}

/// Re-runs the episode of `shown` from its start with `how` applied to the attention at
/// every step (M uniform, steered onto a distractor, a word's weight zeroed).
pub fn start_attention_probe(agent: &Agent, shown: &Shown, how: Loop, alpha: f64) -> Job {
    let agent = agent.clone();
    let trace = shown.trace.clone();
    Job::spawn(format!("re-running with {how:?}"), 0, move |_| {
        let world = trace
            .steps
            .first()
            .map_or_else(|| trace.final_world.clone(), |s| s.world.clone());
        let spec = EpisodeSpec {
            level: trace.level,
            seed: trace.seed,
            mission: None,
            mode: trace.mode,
        };
        let acting = agent.acting();
        let run = run_from_with(acting, &trace.checkpoint, &spec, world, &|w, o, t, m| {
            intervention(acting, how, w, o, t, m)
        });
        match run {
            Ok(t) => JobResult::Probed(Box::new(Shown::new(t, alpha)), 0),
            Err(e) => JobResult::Failed(e.to_string()),
        }
    })
}

/// Starts an export of `shown`; `stop` cancels it.
pub fn start_export(shown: &Shown, what: Export, alpha: f64, stop: Arc<AtomicBool>) -> Job {
    let trace = shown.trace.clone();
    let total = trace.steps.len();
    let label = match &what {
        Export::Rrd(p) | Export::Mcap(p) | Export::Gif(p) => format!("writing {}", p.display()),
        Export::Spawn => "sending to a new Rerun viewer".into(),
        Export::Connect(u) => format!("sending to {u}"),
    };
    Job::spawn(label, total, move |done| {
        let eps = std::slice::from_ref(&*trace);
        let result = match &what {
            Export::Rrd(p) => record_rerun(
                eps,
                &RerunTargets {
                    save: Some(p.clone()),
                    ..RerunTargets::default()
                },
                alpha,
                Some(&stop),
            )
            .map(|_| format!("wrote {}", p.display()))
            .map_err(|e| e.to_string()),
            Export::Spawn | Export::Connect(_) => record_rerun(
                eps,
                &RerunTargets {
                    spawn: what == Export::Spawn,
                    connect: match &what {
                        Export::Connect(u) => Some(u.clone()),
                        _ => None,
                    },
                    ..RerunTargets::default()
                },
                alpha,
                Some(&stop),
            )
            .map(|s| format!("sent {} steps to Rerun", s.steps))
            .map_err(|e| e.to_string()),
            Export::Mcap(p) => write_mcap(eps, p, alpha, Some(&stop))
                .map(|_| format!("wrote {}", p.display()))
                .map_err(|e| e.to_string()),
            Export::Gif(p) => super::gif::write_gif(&trace, p, alpha, done, &stop)
                .map(|()| format!("wrote {}", p.display())),
        };
        done.store(total, Ordering::Relaxed);
        match result {
            Ok(m) => JobResult::Exported(m),
            Err(e) => JobResult::Failed(e),
        }
    })
}

/// Playback over an episode of `len` steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Cursor {
    /// The step shown.
    pub step: usize,
    /// Playing forward.
    pub playing: bool,
    /// Steps per second while playing.
    pub speed: f32,
    /// Seconds accumulated towards the next step.
    pub carry: f32,
}

impl Default for Cursor {
    fn default() -> Self {
        Self {
            step: 0,
            playing: false,
            speed: 4.0,
            carry: 0.0,
        }
    }
}

impl Cursor {
    /// Moves by `delta` steps, clamped to the episode.
    pub fn nudge(&mut self, delta: isize, len: usize) {
        let last = len.saturating_sub(1) as isize;
        self.step = (self.step as isize + delta).clamp(0, last.max(0)) as usize;
    }

    /// Advances playback by `dt` seconds; stops at the last step.
    pub fn tick(&mut self, dt: f32, len: usize) {
        if !self.playing {
            return;
        }
        self.carry += dt * self.speed;
        while self.carry >= 1.0 {
            self.carry -= 1.0;
            if self.step + 1 >= len {
                self.playing = false;
                self.carry = 0.0;
                break;
            }
            self.step += 1;
        }
    }
}

/// The first step after `from` where some evaluated map misses a related object (under
/// `acc_cmb`), wrapping around; `None` if no step has a miss.
pub fn next_miss(scenes: &[StepScene], from: usize) -> Option<usize> {
    let n = scenes.len();
    (1..=n).map(|d| (from + d) % n).find(|&i| {
        scenes[i]
            .grounding
            .iter()
            .any(|g| g.hits.iter().any(|h| !h.acc_cmb))
    })
}

/// The step where the episode failed: the last step of a failed episode.
pub fn failure_step(trace: &EpisodeTrace) -> Option<usize> {
    (!trace.success()).then(|| trace.steps.len().saturating_sub(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shown(seed: u64) -> (Agent, Shown) {
        let agent = Agent::load("bundled:attention").unwrap();
        let req = Request {
            level: agent.level(),
            seed,
            mode: ActionMode::Greedy,
            mission: None,
        };
        let s = run_request(&agent, &req, 0.5).unwrap();
        (agent, s)
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
            Request {
                level: agent.level(),
                seed: 3,
                mode: ActionMode::Greedy,
                mission: None,
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
        if let Some(i) = next_miss(&s.scenes, 0) {
            assert!(
                s.scenes[i]
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
}
