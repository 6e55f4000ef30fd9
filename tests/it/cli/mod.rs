//! The command line: exit codes, one-line errors and what the commands write (`commands`), and
//! the `env` commands (`env`), MiniGrid's own environments in every command (`minigrid`).

mod commands;
mod env;
mod minigrid;
mod minigrid_bundled;
