//! Ctrl-C (and SIGTERM, SIGHUP) during a sweep that writes a report (`eval`, `faithfulness`):
//! the workers stop at their next step, the staged output is removed, the output directory
//! is left as it was, and one line on stderr says so; the exit status is 130.
//!
//! Without this, the default action of SIGINT killed the process between writes: no word
//! on stderr, and a `faithfulness` run left its hidden staging directory in `--out`.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use groundscope::policy::{ActOutput, Acting, Memory, MissionInputs, PolicyError, Step, Variant};

/// Set by the signal handler; read by the workers between steps.
#[derive(Clone, Debug, Default)]
pub struct Stop(Arc<AtomicBool>);

impl Stop {
    /// Installs the handler. Only one can be installed in a process; when another already
    /// is (never in the binary: one command a process), the flag is simply never set.
    pub fn install() -> Self {
        let stop = Self::default();
        let flag = stop.0.clone();
        let _ = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst));
        stop
    }

    /// Whether a stop was asked for.
    pub fn requested(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }

    /// `agent`, refusing to take another step once a stop was asked for.
    pub fn guard<'a>(&'a self, agent: &'a (dyn Acting + Send + Sync)) -> Stoppable<'a> {
        Stoppable { agent, stop: self }
    }

    /// The line on stderr that says what was kept: nothing of this run, and `out` as it was.
    pub fn report(out: &Path) {
        eprintln!(
            "groundscope: interrupted: nothing was written; {} is as it was before this run",
            out.display()
        );
    }
}

/// What a worker's panic said, as one line for an error message (a panic is a bug, but it
/// must end the command with an error, not leave other threads waiting).
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    format!(
        "a worker failed: {}",
        groundscope::panics::panic_line(payload)
    )
}

/// An agent whose every step first checks the stop flag: a stopped run's workers end at
/// their next step with an error the command replaces by [`Stop::report`].
pub struct Stoppable<'a> {
    agent: &'a (dyn Acting + Send + Sync),
    stop: &'a Stop,
}

impl Stoppable<'_> {
    fn check(&self) -> Result<(), PolicyError> {
        if self.stop.requested() {
            Err(PolicyError::Input("interrupted".into()))
        } else {
            Ok(())
        }
    }
}

impl Acting for Stoppable<'_> {
    fn variant(&self) -> Variant {
        self.agent.variant()
    }

    fn known_words(&self) -> usize {
        self.agent.known_words()
    }

    fn zero_memory(&self) -> Result<Memory, PolicyError> {
        self.agent.zero_memory()
    }

    fn prepare(&self, tokens: &[u32]) -> Result<Option<MissionInputs>, PolicyError> {
        self.check()?;
        self.agent.prepare(tokens)
    }

    fn act_step(&self, step: &Step<'_>) -> Result<ActOutput, PolicyError> {
        self.check()?;
        self.agent.act_step(step)
    }

    fn zero_memory_batch(&self, batch: usize) -> Result<Memory, PolicyError> {
        self.agent.zero_memory_batch(batch)
    }

    fn prepare_batch(&self, missions: &[&[u32]]) -> Result<Option<MissionInputs>, PolicyError> {
        self.check()?;
        self.agent.prepare_batch(missions)
    }

    fn takes_interventions(&self) -> bool {
        self.agent.takes_interventions()
    }

    fn n_actions(&self) -> usize {
        self.agent.n_actions()
    }

    fn model_name(&self) -> Option<String> {
        self.agent.model_name()
    }

    fn input_token_ids(&self, tokens: &[u32]) -> Option<Vec<i64>> {
        self.agent.input_token_ids(tokens)
    }

    fn reads_world(&self) -> bool {
        self.agent.reads_world()
    }

    fn act_from_expert(
        &self,
        advice: &[Option<groundscope::env::Action>],
    ) -> Result<ActOutput, PolicyError> {
        self.check()?;
        self.agent.act_from_expert(advice)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stopped_agent_refuses_its_next_step() {
        let agent = groundscope::policy::Agent::load("bundled:attention").unwrap();
        let stop = Stop::default();
        let guarded = stop.guard(agent.acting());
        let tokens = groundscope::env::vocab::tokenize("go to the red key").unwrap();
        assert!(guarded.prepare(&tokens).is_ok());
        stop.0.store(true, Ordering::SeqCst);
        let e = guarded.prepare(&tokens).unwrap_err().to_string();
        assert!(e.contains("interrupted"), "{e}");
    }
}
