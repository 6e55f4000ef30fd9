//! The step cursor and playback.

use crate::episode::EpisodeTrace;

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

/// The step where the episode failed: the last step of a failed episode.
pub fn failure_step(trace: &EpisodeTrace) -> Option<usize> {
    (!trace.success()).then(|| trace.steps.len().saturating_sub(1))
}
