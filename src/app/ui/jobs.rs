//! Starting the background jobs (episodes, checkpoint loads, exports) and taking in what
//! they finish.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use eframe::egui;

use super::Debugger;
use crate::app::session::{
    Agent, Cursor, Export, JobResult, Request, Shown, start_episodes, start_export,
};
use crate::episode::ActionMode;

impl Debugger {
    pub(super) fn run_episode(&mut self, mission: Option<String>) {
        let Some(agent) = self.agent.clone() else {
            self.error("no checkpoint loaded");
            return;
        };
        let req = Request {
            level: self.level,
            seed: self.seed,
            mode: if self.sample {
                ActionMode::Sampled
            } else {
                ActionMode::Greedy
            },
            mission,
        };
        let compare = if self.compare {
            self.compare_agent.clone()
        } else {
            None
        };
        // The episode asked for last is the one shown: an older one still running stops
        // (its job dropped, its next send fails).
        self.jobs.retain(|j| !j.episode);
        self.streaming = false;
        self.jobs
            .push(start_episodes(agent, compare, req, self.alpha));
    }

    /// Takes in a new main episode (and the compared one): a fresh episode starts at the
    /// step asked for, a later part of the same one keeps the cursor where it is.
    fn take_episode(&mut self, a: Shown, b: Option<Shown>, fresh: bool) {
        if fresh {
            self.generation += 1;
            self.textures.clear();
            self.cursor = Cursor::default();
            self.mission_text.clone_from(&a.trace.mission);
            self.selected_word = 0;
        }
        self.shown = Some(a);
        if b.is_some() || fresh {
            self.compared = b;
        }
        self.go_to_pending_step();
    }

    /// Moves the cursor to `--step K` once step K is there, or to the last step when the
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

    pub(super) fn load_checkpoints(&mut self) {
        match Agent::load(self.checkpoint_text.trim()) {
            Ok(a) => {
                self.level = a.level();
                self.info(format!("loaded {}", a.spec));
                self.agent = Some(a);
            }
            Err(e) => self.error(e),
        }
        if self.compare {
            match Agent::load(self.compare_text.trim()) {
                Ok(a) => self.compare_agent = Some(a),
                Err(e) => {
                    self.error(format!("compare: {e}"));
                    self.compare_agent = None;
                }
            }
        }
        self.run_episode(None);
    }

    pub(super) fn poll_jobs(&mut self, ctx: &egui::Context) {
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
            match r {
                JobResult::Running(a) => {
                    let fresh = !self.streaming;
                    self.streaming = true;
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
                    self.take_episode(a, b, fresh);
                }
                JobResult::Probed(s, k) => {
                    // The probe's episode replaces the one shown, even one still running.
                    self.jobs.retain(|j| !j.episode);
                    self.streaming = false;
                    self.generation += 1;
                    self.textures.clear();
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
                JobResult::Failed(e) => {
                    if from_episode {
                        self.streaming = false;
                    }
                    self.error(e);
                }
            }
        }
        if self.busy() {
            ctx.request_repaint();
        }
        self.receive_shot(ctx);
    }

    pub(super) fn export(&mut self, what: Export) {
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

    pub(super) fn export_path(&self, ext: &str) -> PathBuf {
        PathBuf::from(self.export_dir.trim()).join(format!(
            "groundscope-seed{}-step{}.{ext}",
            self.seed, self.cursor.step
        ))
    }
}
