//! What evaluations write: faithfulness (`faithfulness`), exploration coverage
//! (`exploration`), CSV quoting (`csv_files`), the worst episodes' commands (`commands`), the
//! curves drawn from run logs (`curve`), the summary and figure links of `report.md`
//! (`summary`), and MiniGrid's own failure classes (`minigrid_failures`).

mod commands;
mod csv_files;
mod curve;
mod exploration;
mod faithfulness;
mod minigrid_failures;
mod summary;
