//! groundscope: a transparency viewer and debugger for language-conditioned RL agents whose
//! policy grounds each mission word in what it sees (text-visual attention, PPO, BabyAI and
//! MiniGrid).
//!
//! Data flows one way: [`env`] (the world) → [`policy`] (actions and attention traces) →
//! [`episode`] traces → consumers ([`metrics`], [`record`], the debugger `app`). The map:
//!
//! - [`env`]: BabyAI's 96 levels and MiniGrid's 76 environments, bit for bit with minigrid
//!   3.2.0; pure, no I/O, no ML.
//! - [`bot`]: minigrid's BabyAI bot, a planner with privileged state beside the world.
//! - [`policy`]: the attention model and its baseline (candle), imported ONNX agents, PPO.
//! - [`run`]: a training run's one front door — its spec and the one list of its defaults,
//!   its directory and lock, crash-safe checkpoints, the resume rule (what differs from the
//!   run's own settings), logs and typed errors; `train`, a study's runs and Python's `train`
//!   start runs through it.
//! - [`study`]: seeds × recipes × levels planned into runs, for this machine, Slurm or Ray.
//! - [`episode`]: a checkpoint run on an episode, the trace every consumer reads.
//! - [`metrics`]: grounding, faithfulness, failure classes, sweeps and reports.
//! - [`render`], [`record`]: images of the world and maps; Rerun and MCAP recordings.
//! - `app` (feature `app`): the interactive debugger.
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
