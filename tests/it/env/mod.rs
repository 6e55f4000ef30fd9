//! The world: every BabyAI level against minigrid 3.2.0 (`babyai`), the older minigrid dumps
//! (`fixtures`), property tests (`props`), the gym env (`gym`), the done mode a level id means
//! (`done_mode`), and transparency on every level (`levels`).

mod babyai;
mod done_mode;
mod fixtures;
mod gym;
mod levels;
mod minigrid;
mod props;
