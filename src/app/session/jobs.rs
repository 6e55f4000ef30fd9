//! The jobs that run off the UI thread: episodes, probes, exports and checkpoint loads. Each
//! runs on its own thread and answers on a channel; a panic is its error, never a job the
//! window waits on for ever.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::time::{Duration, Instant};

use super::Agent;
use crate::app::shown::Shown;
use crate::env::World;
use crate::env::edit::{Edit, apply};
use crate::env::level::LevelConfig;
use crate::episode::{
    EpisodeRequest, EpisodeSpec, EpisodeTrace, StepRecord, replay_actions, rerun_from, run_from,
    run_from_observed, run_from_with,
};
use crate::metrics::faithfulness::episode::{Loop, intervention};
use crate::metrics::report::browse::RecordedEpisode;
use crate::panics::panic_line;
use crate::record::{RerunTargets, record_rerun, write_mcap};

/// The result of a background job, or (the first two) news from one still running.
#[derive(Debug)]
pub enum JobResult {
    /// The main episode so far, while the job goes on: its first steps (the next come as
    /// [`JobResult::Steps`]), or the whole of it while the compared one runs.
    Running(Box<Shown>),
    /// The next steps of the main episode [`JobResult::Running`] began.
    Steps(Vec<StepRecord>),
    /// Fresh episodes: the main one and, in compare mode, the second checkpoint's.
    Episodes(Box<(Shown, Option<Shown>)>),
    /// A Python policy's episode replayed read-only from its report (and, in compare mode, the
    /// second checkpoint's on the same level and seed), with the policy's name.
    Replayed(Box<(Shown, Option<Shown>)>, String),
    /// A probe: the main episode re-run from an edited state.
    Probed(Box<Shown>, usize),
    /// A file was written or a stream sent.
    Exported(String),
    /// Checkpoints loaded, and what the session does next.
    Loaded(Box<Loaded>),
    /// Something failed; the message is shown in the UI.
    Failed(String),
}

impl JobResult {
    /// Whether more results follow from the same job.
    pub fn is_progress(&self) -> bool {
        matches!(self, Self::Running(_) | Self::Steps(_))
    }
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
    /// Whether it runs the episode shown (a newer episode drops it).
    pub episode: bool,
    rx: Receiver<JobResult>,
}

impl Job {
    /// A job that runs `work` on its own thread; `work` counts what it has done in its
    /// argument, for the progress bar.
    pub(in crate::app) fn spawn(
        what: String,
        total: usize,
        work: impl FnOnce(&AtomicUsize) -> JobResult + Send + 'static,
    ) -> Self {
        Self::spawn_with(what, total, move |done, _| work(done))
    }

    /// A job that also sends progress ([`JobResult::is_progress`]) on the channel it is
    /// given; a send fails once the job has been dropped, which tells the work to stop.
    fn spawn_with(
        what: String,
        total: usize,
        work: impl FnOnce(&AtomicUsize, &Sender<JobResult>) -> JobResult + Send + 'static,
    ) -> Self {
        let (tx, rx) = channel();
        let done = Arc::new(AtomicUsize::new(0));
        let d = done.clone();
        let label = what.clone();
        std::thread::spawn(move || {
            // A panic is the job's error, shown in the window (and the end of a headless
            // screenshot), not a job the window waits on for ever.
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&d, &tx)))
                .unwrap_or_else(|p| {
                    JobResult::Failed(format!("{label} failed: {}", panic_line(p.as_ref())))
                });
            let _ = tx.send(result);
        });
        Self {
            what,
            done,
            total,
            episode: false,
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
    /// Progress on the way is skipped.
    pub fn wait(self) -> JobResult {
        loop {
            match self.rx.recv() {
                Ok(r) if r.is_progress() => {}
                Ok(r) => return r,
                Err(_) => return JobResult::Failed(format!("{} stopped", self.what)),
            }
        }
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

/// Runs `agent` on `req` (whose checkpoint `agent` is).
pub fn run_request(agent: &Agent, req: &EpisodeRequest, alpha: f64) -> Result<Shown, String> {
    let spec = req.spec();
    let world = crate::episode::initial_world(&spec).map_err(|e| e.to_string())?;
    let trace = run_from(agent.acting(), &agent.spec, &spec, world).map_err(|e| e.to_string())?;
    Ok(Shown::new(trace, alpha))
}

/// How often a running episode sends its new steps: the window redraws no more often than
/// this for them.
const STEPS_EVERY: Duration = Duration::from_millis(40);

/// Runs `agent` on `req`, sending its first step as [`JobResult::Running`] as soon as it is
/// taken and the next ones as [`JobResult::Steps`] every [`STEPS_EVERY`]. `None` when the
/// receiver is gone (a newer episode replaced this one).
pub fn stream_request(
    agent: &Agent,
    req: &EpisodeRequest,
    alpha: f64,
    tx: &Sender<JobResult>,
) -> Result<Option<Shown>, String> {
    let spec = req.spec();
    let world = crate::episode::initial_world(&spec).map_err(|e| e.to_string())?;
    let (mut sent, mut last_sent, mut open) = (0, Instant::now(), true);
    let trace = run_from_observed(
        agent.acting(),
        &agent.spec,
        &spec,
        world,
        &mut |so_far: &EpisodeTrace| {
            let n = so_far.steps.len();
            if sent == 0 {
                let first = Shown::running(so_far.clone(), alpha);
                open = tx.send(JobResult::Running(Box::new(first))).is_ok();
                (sent, last_sent) = (n, Instant::now());
            } else if last_sent.elapsed() >= STEPS_EVERY {
                let steps = so_far.steps[sent..].to_vec();
                open = tx.send(JobResult::Steps(steps)).is_ok();
                (sent, last_sent) = (n, Instant::now());
            }
            open
        },
    )
    .map_err(|e| e.to_string())?;
    Ok(open.then(|| Shown::new(trace, alpha)))
}

/// Starts running the main (and compared) agent on `req`: the main episode's steps come as
/// they are taken ([`stream_request`]), then the whole of both.
pub fn start_episodes(main: Agent, compare: Option<Agent>, req: EpisodeRequest, alpha: f64) -> Job {
    let what = format!("running seed {}", req.seed);
    let mut job = Job::spawn_with(what, 0, move |_, tx| {
        let a = match stream_request(&main, &req, alpha, tx) {
            Ok(Some(a)) => a,
            Ok(None) => return JobResult::Failed("replaced by a newer episode".into()),
            Err(e) => return JobResult::Failed(e),
        };
        if compare.is_some() {
            let _ = tx.send(JobResult::Running(Box::new(a.clone())));
        }
        let b = match compare
            .as_ref()
            .map(|c| run_request(c, &req, alpha))
            .transpose()
        {
            Ok(b) => b,
            Err(e) => return JobResult::Failed(format!("compared checkpoint: {e}")),
        };
        JobResult::Episodes(Box::new((a, b)))
    });
    job.episode = true;
    job
}

/// Starts replaying a Python policy's episode from the actions its report recorded
/// ([`replay_actions`]): the policy is not run (nor loaded: its name is no checkpoint's), and
/// `compare`, where given, runs on the same level and seed beside it.
pub fn start_replay(rec: RecordedEpisode, compare: Option<Agent>, alpha: f64) -> Job {
    let what = format!("replaying seed {} from the report", rec.seed);
    let mut job = Job::spawn(what, 0, move |_| {
        let trace = match replay_actions(&rec.label(), &rec.spec(), &rec.actions) {
            Ok(t) => t,
            Err(e) => return JobResult::Failed(format!("{}: {e}", rec.label())),
        };
        let a = Shown::new(trace, alpha);
        // The compared checkpoint's own run: `run_request` names it by its agent.
        let req = EpisodeRequest {
            mode: rec.mode,
            step: rec.step,
            ..EpisodeRequest::new(String::new(), rec.level, rec.seed)
        };
        let b = match compare
            .as_ref()
            .map(|c| run_request(c, &req, alpha))
            .transpose()
        {
            Ok(b) => b,
            Err(e) => return JobResult::Failed(format!("compared checkpoint: {e}")),
        };
        JobResult::Replayed(Box::new((a, b)), rec.policy)
    });
    job.episode = true;
    job
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
            Export::Gif(p) => crate::app::gif::write_gif(&trace, p, alpha, done, &stop)
                .map(|()| format!("wrote {}", p.display())),
        };
        done.store(total, Ordering::Relaxed);
        match result {
            Ok(m) => JobResult::Exported(m),
            Err(e) => JobResult::Failed(e),
        }
    })
}

/// Checkpoints loaded off the UI thread ([`start_load`], [`start_fallback`]), and what the
/// session does with them ([`super::Session::poll_jobs`]).
#[derive(Debug)]
pub struct Loaded {
    /// The main checkpoint, where one was asked for.
    pub main: Option<Result<Agent, String>>,
    /// The compared checkpoint, where one was asked for.
    pub compare: Option<Result<Agent, String>>,
    /// What follows.
    pub then: AfterLoad,
}

/// What follows a checkpoint load.
#[derive(Debug)]
pub enum AfterLoad {
    /// The first episode: the level the debugger opened with, each load error said.
    Start,
    /// The top bar's "load": the main checkpoint's own level, "loaded NAME" said.
    Load,
    /// A level the agent could not read: this model acts instead, and the message says why.
    Fallback(String),
    /// A report's episode, opened with the checkpoint it names.
    Open(EpisodeRequest),
    /// The report's "compare with": the compared checkpoint beside the report's episode
    /// selected (an index into its rows), else beside the episode asked for.
    Compare(Option<usize>),
}

/// Loads `main` and `compare` (either may be absent) on another thread; `then` says what the
/// session does once they are loaded.
pub fn start_load(main: Option<String>, compare: Option<String>, then: AfterLoad) -> Job {
    let names: Vec<&str> = main.iter().chain(&compare).map(String::as_str).collect();
    let what = format!("loading {}", names.join(" and "));
    Job::spawn(what, 0, move |_| {
        JobResult::Loaded(Box::new(Loaded {
            main: main.as_deref().map(Agent::load),
            compare: compare.as_deref().map(Agent::load),
            then,
        }))
    })
}

/// Loads a model that reads `world`'s mission on another thread: `bundled:minigrid` on
/// MiniGrid's own ids, `bundled:babyai` where it reads the mission, else minigrid's bot.
/// `said` begins the message that says so ("X cannot read this level (why)").
pub fn start_fallback(level: LevelConfig, world: World, said: String) -> Job {
    Job::spawn(
        "loading a model that reads this level".into(),
        0,
        move |_| {
            let reads = |a: &Agent| {
                crate::policy::acting::world_tokens(a.policy.acting(), &world, || level.to_string())
            };
            let (name, what) = if level.is_minigrid() {
                (
                    crate::policy::bundled::MINIGRID,
                    "the bundled MiniGrid model",
                )
            } else {
                (crate::policy::bundled::BABYAI, "the bundled BabyAI model")
            };
            let bundled = Agent::load(name).ok().filter(|b| reads(b).is_ok());
            let (main, what) = match bundled {
                Some(b) => (Ok(b), what),
                None => (
                    Agent::load(crate::policy::acting::BOT),
                    "minigrid's bot (checkpoint \"bot\")",
                ),
            };
            JobResult::Loaded(Box::new(Loaded {
                main: Some(main),
                compare: None,
                then: AfterLoad::Fallback(format!("{said}: running {what} instead")),
            }))
        },
    )
}
