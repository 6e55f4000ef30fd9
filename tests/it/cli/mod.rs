//! The command line: exit codes, one-line errors and what the commands write (`commands`), and
//! the `env` commands (`env`).

mod commands;
mod env;
