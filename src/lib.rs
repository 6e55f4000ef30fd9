//! groundscope: a transparency viewer and debugger for language-conditioned RL agents whose
//! policy grounds each mission word in what it sees (text-visual attention, PPO, BabyAI).
//!
//! Data flows one way: [`env`] (the world) → `policy` (actions and attention traces) →
//! episode traces → consumers (metrics, recordings, the debugger).
//!
//! Coordinates follow MiniGrid: arrays are x-major (`grid[x][y]`, `image[vx][vy]`), `y` grows
//! downward; in the agent's 7×7 view the agent sits at `(3, 6)` facing up. Displays show the
//! view agent-up: row = `vy`, column = `vx`.

#[cfg(feature = "app")]
pub mod app;
pub mod bot;
pub mod env;
pub mod episode;
pub mod files;
pub mod metrics;
pub mod panics;
pub mod policy;
pub mod record;
pub mod render;
pub mod run;
pub mod stats;
pub mod study;
pub mod table;
