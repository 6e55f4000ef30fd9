//! An episode as the debugger holds it: its trace, which grows while the episode still runs
//! (the first step is shown at once), and its step scenes, computed when a panel first asks
//! for one and kept for the last few steps asked for only. A scene's pictures weigh about
//! 0.4 MB on a 22×22 world, so keeping all 1,728 of a BossLevel episode cost 700 MB; a
//! window of [`SCENES_KEPT`] costs the same on every episode length.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use crate::episode::{EpisodeTrace, StepRecord};
use crate::metrics::failure::{Diagnosis, Evidence, decisive_step, first_divergence};
use crate::record::StepScene;
use crate::record::scene::step_grounding;

/// How many step scenes an episode keeps: enough for the step shown, the compared episode's
/// and playback's next steps; the rest are recomputed (about 1 ms each) when asked again.
pub const SCENES_KEPT: usize = 32;

/// The most recently asked-for scenes, newest last.
#[derive(Debug, Default)]
struct SceneWindow {
    recent: VecDeque<(usize, Arc<StepScene>)>,
}

/// An episode with its per-step scenes.
#[derive(Clone, Debug)]
pub struct Shown {
    /// The trace: every step once the episode is complete, the steps taken so far while it
    /// runs.
    pub trace: Arc<EpisodeTrace>,
    /// Why the episode failed, as `eval` classifies it (`None` for a success, and while the
    /// episode runs).
    pub failure: Option<Diagnosis>,
    /// Where a failed episode was lost ([`decisive_step`]: the act its MiniGrid class or
    /// behaviour names, else its first divergence from the bot that matters, else its last
    /// step), as `eval` gives it.
    pub decisive: Option<usize>,
    complete: bool,
    alpha: f64,
    scenes: Arc<Mutex<SceneWindow>>,
}

impl Shown {
    /// A complete episode; its scenes are grounded with `alpha`.
    pub fn new(trace: EpisodeTrace, alpha: f64) -> Self {
        let failure = Evidence::from_trace(&trace).diagnose();
        let length = u32::try_from(trace.steps.len()).unwrap_or(u32::MAX);
        let decisive = failure
            .as_ref()
            .map(|d| decisive_step(d.lost_at, first_divergence(&trace), length) as usize);
        Self {
            trace: Arc::new(trace),
            failure,
            decisive,
            complete: true,
            alpha,
            scenes: Arc::default(),
        }
    }

    /// The first steps of an episode that is still running; [`Self::extend`] adds the next.
    pub fn running(trace: EpisodeTrace, alpha: f64) -> Self {
        Self {
            trace: Arc::new(trace),
            failure: None,
            decisive: None,
            complete: false,
            alpha,
            scenes: Arc::default(),
        }
    }

    /// Appends steps of a running episode. The scenes already computed stay valid: a step's
    /// scene depends on that step alone.
    pub fn extend(&mut self, steps: Vec<StepRecord>) {
        let trace = Arc::make_mut(&mut self.trace);
        if let Some(last) = steps.last() {
            trace.final_world = last.world.clone();
        }
        trace.steps.extend(steps);
    }

    /// Whether every step of the episode is there.
    pub fn is_complete(&self) -> bool {
        self.complete
    }

    /// Steps in the episode (so far, while it runs).
    pub fn len(&self) -> usize {
        self.trace.steps.len()
    }

    /// Whether the episode has no step (yet).
    pub fn is_empty(&self) -> bool {
        self.trace.steps.is_empty()
    }

    /// The scene of step `i`, computed now unless it is among the last [`SCENES_KEPT`] asked
    /// for; `None` past the steps there are.
    pub fn scene(&self, i: usize) -> Option<Arc<StepScene>> {
        let step = self.trace.steps.get(i)?;
        // A poisoned lock (a panic elsewhere while it was held) only costs the caching.
        let mut window = self.scenes.lock().ok();
        if let Some(w) = window.as_mut()
            && let Some(at) = w.recent.iter().position(|(k, _)| *k == i)
        {
            let hit = w.recent.remove(at)?;
            let scene = hit.1.clone();
            w.recent.push_back(hit);
            return Some(scene);
        }
        let scene = Arc::new(StepScene::new(step, self.alpha));
        if let Some(w) = window.as_mut() {
            if w.recent.len() >= SCENES_KEPT {
                w.recent.pop_front();
            }
            w.recent.push_back((i, scene.clone()));
        }
        Some(scene)
    }

    /// How many scenes are kept now (never more than [`SCENES_KEPT`]).
    pub fn scenes_kept(&self) -> usize {
        self.scenes.lock().map_or(0, |w| w.recent.len())
    }

    /// The threshold's `alpha` the scenes are grounded with.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }
}

/// The first step after `from` where some evaluated map misses a related object (under
/// `acc_cmb`), wrapping around; `None` if no step has a miss. Grounds the steps one by one
/// without drawing them.
pub fn next_miss(shown: &Shown, from: usize) -> Option<usize> {
    let steps = &shown.trace.steps;
    let n = steps.len();
    (1..=n).map(|d| (from + d) % n).find(|&i| {
        step_grounding(&steps[i], shown.alpha)
            .iter()
            .any(|g| g.hits.iter().any(|h| !h.acc_cmb))
    })
}
