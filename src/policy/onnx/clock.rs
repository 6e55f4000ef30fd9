//! What an ONNX agent's steps cost: counters kept while it runs, read by `bench onnx`.

/// Where an agent's step time went, summed over its life (for `bench onnx`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepTimes {
    /// Calls of [`OnnxAgent::step`].
    pub steps: u64,
    /// Graph runs (one per mission length in a step).
    pub runs: u64,
    /// Runs of the mission encoder cut from the graph (docs/onnx.md#speed): one per step
    /// that meets missions not seen before; 0 for a graph that is not cut.
    pub encoder_runs: u64,
    /// Seconds inside tract's plans (the step graph and the mission encoder).
    pub graph_secs: f64,
    /// Seconds in [`OnnxAgent::step`] in all: the graph, plus building its inputs and reading
    /// its outputs.
    pub step_secs: f64,
}

impl StepTimes {
    /// What was spent since `before` (an earlier reading of the same agent).
    #[must_use]
    pub fn since(&self, before: &Self) -> Self {
        Self {
            steps: self.steps - before.steps,
            runs: self.runs - before.runs,
            encoder_runs: self.encoder_runs - before.encoder_runs,
            graph_secs: self.graph_secs - before.graph_secs,
            step_secs: self.step_secs - before.step_secs,
        }
    }
}

/// Nanosecond counters behind [`StepTimes`] (atomics: sweeps step one agent from threads).
#[derive(Debug, Default)]
pub(super) struct Clock {
    pub(super) steps: std::sync::atomic::AtomicU64,
    pub(super) runs: std::sync::atomic::AtomicU64,
    pub(super) encoder_runs: std::sync::atomic::AtomicU64,
    pub(super) graph_ns: std::sync::atomic::AtomicU64,
    pub(super) step_ns: std::sync::atomic::AtomicU64,
}

impl Clock {
    pub(super) fn add(counter: &std::sync::atomic::AtomicU64, since: std::time::Instant) {
        let ns = u64::try_from(since.elapsed().as_nanos()).unwrap_or(u64::MAX);
        counter.fetch_add(ns, std::sync::atomic::Ordering::Relaxed);
    }
}
