//! Bad and hostile inputs, by surface: outputs, signals and run directories (`outputs`; a
//! failure that must leave the user's files as they were, `outputs2`), files
//! and text read as inputs (`inputs`), imported graphs and interrupted sweeps (`graphs`),
//! training and resume edge cases (`training`), the command line's messages (`cli`), and fuzzed
//! checkpoints, snapshots and run states (`fuzz`).

mod cli;
mod fuzz;
mod graphs;
mod inputs;
mod outputs;
mod outputs2;
mod training;
