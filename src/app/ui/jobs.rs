//! Starting the background jobs (episodes, checkpoint loads, exports) and taking in what
//! they finish.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use eframe::egui;

use super::Debugger;
use crate::app::session::{
    Agent, Cursor, Export, JobResult, Request, start_episodes, start_export,
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
        self.jobs
            .push(start_episodes(agent, compare, req, self.alpha));
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
        self.jobs.retain(|job| match job.poll() {
            Some(r) => {
                finished.push(r);
                false
            }
            None => true,
        });
        for r in finished {
            match r {
                JobResult::Episodes(pair) => {
                    let (a, b) = *pair;
                    self.generation += 1;
                    self.textures.clear();
                    let step = self.pending_step.take().unwrap_or(0);
                    let last = a.len().saturating_sub(1);
                    if step > last {
                        // Said once, on stderr and in the window, rather than clamped
                        // silently.
                        let m = format!(
                            "--step {step} is past this episode's last step {last}; showing step {last}"
                        );
                        eprintln!("groundscope: warning: {m}");
                        self.error(m);
                    }
                    self.cursor = Cursor {
                        step: step.min(last),
                        ..Cursor::default()
                    };
                    self.mission_text.clone_from(&a.trace.mission);
                    self.shown = Some(a);
                    self.compared = b;
                    self.selected_word = 0;
                }
                JobResult::Probed(s, k) => {
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
                JobResult::Failed(e) => self.error(e),
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
