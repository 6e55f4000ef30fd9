//! The debugger's model, free of any UI: the agents loaded, the one episode asked for
//! ([`EpisodeRequest`]), the episodes shown, the step cursor and playback, what is selected,
//! the evaluation browsed, and the jobs that run off the UI thread (episodes, probes, exports,
//! checkpoint loads). Every panel reads and changes a [`Session`]; everything here is testable
//! without a display.

mod agent;
mod cursor;
mod jobs;
mod report;
mod selection;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

pub use super::shown::{SCENES_KEPT, Shown, next_miss};
pub use agent::Agent;
pub use cursor::{Cursor, failure_step};
pub use jobs::{
    AfterLoad, Export, Job, JobResult, Loaded, run_request, start_attention_probe, start_episodes,
    start_export, start_fallback, start_load, start_probe, start_replay, stream_request,
};
pub use selection::{FOLD_ABOVE_WORDS, Overlay, Selection};

use super::episodes::Browser;
use crate::env::edit::Edit;
pub use crate::episode::EpisodeRequest;

/// Everything the debugger holds but its pictures and its panels' own fields.
#[derive(Debug)]
pub struct Session {
    /// The agent of the episode shown (`None` until its checkpoint has loaded, or when it
    /// failed to).
    pub agent: Option<Agent>,
    /// The second checkpoint of compare mode, once loaded.
    pub compare_agent: Option<Agent>,
    /// Whether compare mode is on.
    pub compare: bool,
    /// The compared checkpoint as typed in the top bar.
    pub compare_text: String,
    /// The episode asked for: its checkpoint (the top bar's field), level, seed and action
    /// mode as the controls show them, the step it opens at and a mission override for its
    /// next run.
    pub request: EpisodeRequest,
    /// The mission field: the episode's mission, or what is being typed in its place.
    pub mission_text: String,
    /// The main episode, once its first step is there.
    pub shown: Option<Shown>,
    /// The compared checkpoint's episode.
    pub compared: Option<Shown>,
    /// The step shown and playback.
    pub cursor: Cursor,
    /// What is selected on the step shown.
    pub selection: Selection,
    /// The jobs running.
    pub jobs: Vec<Job>,
    /// Cancels the running export.
    pub cancel: Arc<AtomicBool>,
    /// The window's messages, oldest first; `true` marks an error.
    pub messages: Vec<(bool, String)>,
    /// Counts the episodes shown: what is cached for one (pictures, measures) is keyed by it.
    pub generation: u64,
    /// The grounding threshold's α.
    pub alpha: f64,
    /// The evaluation browsed in the episodes panel.
    pub report: Option<Browser>,
    /// The Python policy whose episode is shown, replayed read-only from its report
    /// ([`crate::metrics::report::browse::RecordedEpisode`]); `None` for an episode an agent
    /// runs. No probe or faithfulness measure runs on it: there is no policy to run.
    pub read_only: Option<String>,
    /// Whether `shown` is an episode whose steps are still coming.
    streaming: bool,
    /// The step to move to once it is there ([`EpisodeRequest::step`]).
    pending_step: Option<usize>,
}

impl Session {
    /// A session that loads the checkpoints of `launch` (off the UI thread) and then runs its
    /// episode.
    pub fn new(launch: &super::Launch) -> Self {
        let request = launch.request.clone();
        let main = request.checkpoint.clone();
        let mut me = Self {
            agent: None,
            compare_agent: None,
            compare: false,
            compare_text: launch.compare.clone().unwrap_or_else(|| {
                crate::policy::bundled::baseline_beside(&request.checkpoint).into()
            }),
            mission_text: request.mission.clone().unwrap_or_default(),
            pending_step: Some(request.step),
            request,
            shown: None,
            streaming: false,
            compared: None,
            cursor: Cursor::default(),
            selection: Selection::default(),
            jobs: Vec::new(),
            cancel: Arc::new(AtomicBool::new(false)),
            messages: Vec::new(),
            generation: 0,
            alpha: 0.5,
            report: launch.report.clone(),
            read_only: None,
        };
        // A Python policy's episode has no checkpoint to load: it is replayed from the report
        // (beside the compared checkpoint, once that has loaded).
        let replayed = launch
            .report
            .as_ref()
            .and_then(|b| b.selected.filter(|&i| b.is_python(i)));
        match replayed {
            Some(i) if launch.compare.is_some() => {
                me.compare = true;
                me.jobs.push(start_load(
                    None,
                    launch.compare.clone(),
                    AfterLoad::Compare(Some(i)),
                ));
            }
            Some(i) => me.open_report_episode(i),
            None => me.jobs.push(start_load(
                Some(main),
                launch.compare.clone(),
                AfterLoad::Start,
            )),
        }
        me
    }

    /// Says `m` in the message bar.
    pub fn info(&mut self, m: impl Into<String>) {
        self.messages.push((false, m.into()));
    }

    /// Says `m` in the message bar, as an error.
    pub fn error(&mut self, m: impl Into<String>) {
        self.messages.push((true, m.into()));
    }

    /// The last message, if it is an error.
    pub fn last_error(&self) -> Option<&str> {
        self.messages
            .last()
            .and_then(|(err, m)| err.then_some(m.as_str()))
    }

    /// Whether a job is running.
    pub fn busy(&self) -> bool {
        !self.jobs.is_empty()
    }

    /// Steps in the main episode (so far, while it runs); 0 before it is there.
    pub fn len(&self) -> usize {
        self.shown.as_ref().map_or(0, Shown::len)
    }

    /// Whether there is no step to show (yet).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// How far the main episode has come: its steps so far and whether it is complete;
    /// `None` before its first step is there.
    pub fn episode_progress(&self) -> Option<(usize, bool)> {
        let shown = self.shown.as_ref()?;
        Some((shown.len(), shown.is_complete() && !self.streaming))
    }

    /// Moves the cursor to step `k`, or to the last step there is.
    pub fn go_to_step(&mut self, k: usize) {
        self.cursor.step = k.min(self.len().saturating_sub(1));
    }

    /// Whether the agent is minigrid's bot, which acts from the world itself (no maps, no
    /// network to probe).
    pub fn agent_is_bot(&self) -> bool {
        self.agent
            .as_ref()
            .is_some_and(|a| a.policy.acting().reads_world())
    }

    /// Runs the episode asked for with the agents loaded (the second beside it in compare
    /// mode). The request's mission override applies to this run only; the episode asked for
    /// last is the one shown, an older one still running stops.
    pub fn run_episode(&mut self) {
        let mission = self.request.mission.take();
        let Some(agent) = self.agent.clone() else {
            self.error(if self.read_only.is_some() {
                "no checkpoint loaded: the Python policy's episodes are replayed from the report; name a checkpoint and load it to run one"
            } else {
                "no checkpoint loaded"
            });
            return;
        };
        let request = EpisodeRequest {
            mission,
            ..self.request.clone()
        };
        let compare = if self.compare {
            self.compare_agent.clone()
        } else {
            None
        };
        // An older episode's job is dropped: its next send fails and it stops.
        self.jobs.retain(|j| !j.episode);
        self.streaming = false;
        self.jobs
            .push(start_episodes(agent, compare, request, self.alpha));
    }

    /// Opens `request`: loads its checkpoint first (off the UI thread) unless it is the one
    /// acting, then runs it at its step with its level's own mission.
    pub fn open(&mut self, request: EpisodeRequest) {
        if self
            .agent
            .as_ref()
            .is_some_and(|a| a.spec == request.checkpoint)
        {
            self.open_now(request);
        } else {
            let main = Some(request.checkpoint.clone());
            self.jobs
                .push(start_load(main, None, AfterLoad::Open(request)));
        }
    }

    /// [`Self::open`] with its checkpoint loaded.
    fn open_now(&mut self, request: EpisodeRequest) {
        self.mission_text.clear();
        self.pending_step = Some(request.step);
        self.request = request;
        self.run_episode();
    }

    /// The top bar's "load": the checkpoint named (and, in compare mode, the compared one),
    /// loaded off the UI thread; the main one's own level and a fresh episode follow.
    pub fn load_checkpoints(&mut self) {
        let main = Some(self.request.checkpoint.trim().to_owned());
        let compare = self.compare.then(|| self.compare_text.trim().to_owned());
        self.jobs.push(start_load(main, compare, AfterLoad::Load));
    }

    /// Where the agent cannot read the level asked for (a word it was not trained on), starts
    /// loading `bundled:babyai` to act instead — or minigrid's bot where even it cannot — whose
    /// episode follows, the message bar saying why. False where the agent reads it (or the
    /// level does not generate), and nothing was started.
    pub fn fallback_where_unreadable(&mut self) -> bool {
        let Some(agent) = &self.agent else {
            return false;
        };
        let level = self.request.level;
        let Ok(world) = level.generate(self.request.seed) else {
            return false;
        };
        let read = crate::policy::acting::world_tokens(agent.policy.acting(), &world, || {
            level.to_string()
        });
        let Err(e) = read else {
            return false;
        };
        let said = format!("{} cannot read this level ({e})", agent.spec);
        self.jobs.push(start_fallback(level, world, said));
        true
    }

    /// Applies `edit` to the world at the cursor and re-runs the agent from there; a refused
    /// edit is said with its reason.
    pub fn probe(&mut self, edit: &Edit) {
        if let Some(policy) = &self.read_only {
            let m = format!(
                "edit refused: {}; there is no policy to re-run from the edited step",
                crate::metrics::report::browse::read_only_line(policy)
            );
            self.error(m);
            return;
        }
        let (Some(agent), Some(shown)) = (&self.agent, &self.shown) else {
            return;
        };
        match start_probe(agent, shown, self.cursor.step, edit, self.alpha) {
            Ok(job) => self.jobs.push(job),
            Err(e) => self.error(format!("edit refused: {e}")),
        }
    }

    /// Turns the agent at the cursor by `by` quarter turns clockwise (a probe).
    pub fn turn(&mut self, by: u8) {
        let dir = self
            .shown
            .as_ref()
            .and_then(|s| s.trace.steps.get(self.cursor.step))
            .map(|s| (s.world.agent_dir + by) % 4);
        if let Some(d) = dir {
            self.probe(&Edit::TurnAgent(d));
        }
    }

    /// Starts exporting the main episode once it has ended.
    pub fn export(&mut self, what: Export) {
        let Some(shown) = &self.shown else {
            return;
        };
        if !shown.is_complete() {
            self.info("the episode is still running: export it once it has ended");
            return;
        }
        self.cancel = Arc::new(AtomicBool::new(false));
        let job = start_export(shown, what, self.alpha, self.cancel.clone());
        self.jobs.push(job);
    }

    /// Where an export of kind `ext` goes in `dir`: named by the seed and step.
    pub fn export_path(&self, dir: &str, ext: &str) -> PathBuf {
        Path::new(dir.trim()).join(format!(
            "groundscope-seed{}-step{}.{ext}",
            self.request.seed, self.cursor.step
        ))
    }

    /// The picture the world panel shows now (the main episode at the cursor, with the chosen
    /// overlay): objects in their true colours, the floor tinted by the map, targets
    /// outlined, the trail dotted. `None` before the first episode.
    pub fn world_image(&self) -> Option<image::RgbImage> {
        let shown = self.shown.as_ref()?;
        let step = self.cursor.step.min(shown.len().saturating_sub(1));
        let minigrid = shown
            .trace
            .steps
            .get(step)
            .is_some_and(|s| s.world.rules.is_some());
        super::pictures::picture(
            shown,
            step,
            self.selection.world_kind(),
            self.selection.own_scale(minigrid),
        )
    }

    /// Takes in what the jobs have finished (and the news of those still running).
    pub fn poll_jobs(&mut self) {
        let mut finished = Vec::new();
        self.jobs.retain(|job| {
            while let Some(r) = job.poll() {
                let more = r.is_progress();
                finished.push((job.episode, r));
                if !more {
                    return false;
                }
            }
            true
        });
        for (from_episode, r) in finished {
            self.take(from_episode, r);
        }
    }

    /// Takes in one job's result.
    fn take(&mut self, from_episode: bool, r: JobResult) {
        match r {
            JobResult::Running(a) => {
                let fresh = !self.streaming;
                self.streaming = true;
                self.read_only = None;
                self.take_episode(*a, None, fresh);
            }
            JobResult::Steps(steps) => {
                if let Some(shown) = self.shown.as_mut()
                    && self.streaming
                {
                    shown.extend(steps);
                }
                self.go_to_pending_step();
            }
            JobResult::Episodes(pair) => {
                let (a, b) = *pair;
                let fresh = !self.streaming;
                self.streaming = false;
                self.read_only = None;
                self.take_episode(a, b, fresh);
            }
            JobResult::Replayed(pair, policy) => {
                let (a, b) = *pair;
                self.streaming = false;
                self.read_only = Some(policy);
                self.take_episode(a, b, true);
            }
            JobResult::Probed(s, k) => {
                // The probe's episode replaces the one shown, even one still running.
                self.jobs.retain(|j| !j.episode);
                self.streaming = false;
                self.generation += 1;
                self.info(format!(
                    "re-ran from step {k}: {} in {} steps",
                    if s.trace.success() {
                        "success"
                    } else {
                        "failure"
                    },
                    s.len()
                ));
                self.mission_text = s
                    .trace
                    .steps
                    .get(k)
                    .map_or_else(|| s.trace.mission.clone(), |st| st.world.mission.clone());
                self.cursor.step = k.min(s.len().saturating_sub(1));
                self.shown = Some(*s);
            }
            JobResult::Exported(m) => self.info(m),
            JobResult::Loaded(loaded) => self.take_loaded(*loaded),
            JobResult::Failed(e) => {
                if from_episode {
                    self.streaming = false;
                }
                self.error(e);
            }
        }
    }

    /// Takes in a new main episode (and the compared one): a fresh episode starts at the
    /// step asked for, a later part of the same one keeps the cursor where it is.
    fn take_episode(&mut self, a: Shown, b: Option<Shown>, fresh: bool) {
        if fresh {
            self.generation += 1;
            self.cursor = Cursor::default();
            self.mission_text.clone_from(&a.trace.mission);
            self.selection.word = 0;
        }
        self.shown = Some(a);
        if b.is_some() || fresh {
            self.compared = b;
        }
        self.go_to_pending_step();
    }

    /// Moves the cursor to the step asked for once it is there, or to the last step when the
    /// episode ended before it.
    fn go_to_pending_step(&mut self) {
        let (Some(step), Some(shown)) = (self.pending_step, &self.shown) else {
            return;
        };
        let last = shown.len().saturating_sub(1);
        if step <= last {
            self.cursor.step = step;
        } else if shown.is_complete() {
            // Said once, on stderr and in the window, rather than clamped silently.
            let m = format!(
                "--step {step} is past this episode's last step {last}; showing step {last}"
            );
            eprintln!("groundscope: warning: {m}");
            self.error(m);
            self.cursor.step = last;
        } else {
            return;
        }
        self.pending_step = None;
    }

    /// Takes in loaded checkpoints and does what was to follow ([`AfterLoad`]).
    fn take_loaded(&mut self, loaded: Loaded) {
        let Loaded {
            main,
            compare,
            then,
        } = loaded;
        match then {
            AfterLoad::Start => {
                match main {
                    Some(Ok(a)) => self.agent = Some(a),
                    Some(Err(e)) => self.error(e),
                    None => {}
                }
                match compare {
                    Some(Ok(a)) => {
                        self.compare_agent = Some(a);
                        self.compare = true;
                    }
                    Some(Err(e)) => self.error(format!("compare: {e}")),
                    None => {}
                }
                self.run_episode();
            }
            AfterLoad::Load => {
                match main {
                    Some(Ok(a)) => {
                        self.request.level = a.level();
                        self.info(format!("loaded {}", a.spec));
                        self.agent = Some(a);
                    }
                    Some(Err(e)) => self.error(e),
                    None => {}
                }
                match compare {
                    Some(Ok(a)) => self.compare_agent = Some(a),
                    Some(Err(e)) => {
                        self.error(format!("compare: {e}"));
                        self.compare_agent = None;
                    }
                    None => {}
                }
                self.run_episode();
            }
            AfterLoad::Fallback(said) => {
                match main {
                    Some(Ok(a)) => {
                        self.info(said);
                        self.request.checkpoint.clone_from(&a.spec);
                        self.agent = Some(a);
                    }
                    Some(Err(e)) => self.error(e),
                    None => {}
                }
                self.run_episode();
            }
            AfterLoad::Open(request) => match main {
                Some(Err(e)) => self.error(format!("{}: {e}", request.checkpoint)),
                Some(Ok(a)) => {
                    self.agent = Some(a);
                    self.open_now(request);
                }
                None => self.open_now(request),
            },
            AfterLoad::Compare(selected) => {
                match compare {
                    Some(Ok(a)) => self.compare_agent = Some(a),
                    Some(Err(e)) => self.error(format!("compare: {e}")),
                    None => {}
                }
                match selected {
                    Some(i) => self.open_report_episode(i),
                    None => self.run_episode(),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
