//! The debugger: its panels through egui's test harness and a real frame under Xvfb
//! (`ui`), the maps in view at every window size (`layout`), any BabyAI level in it
//! (`levels`), MiniGrid's own environments (`minigrid`), and an evaluation's report browsed
//! in it (`view_report`).

mod layout;
mod levels;
mod minigrid;
mod ui;
mod view_report;
