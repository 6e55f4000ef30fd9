//! What evaluations write: faithfulness (`faithfulness`), exploration coverage
//! (`exploration`), CSV quoting (`csv_files`), the worst episodes' commands (`commands`), and
//! the curves drawn from run logs (`curve`).

mod commands;
mod csv_files;
mod curve;
mod exploration;
mod faithfulness;
