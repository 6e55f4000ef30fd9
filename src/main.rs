//! The `groundscope` command line.

mod cli;

/// mimalloc keeps freed tensor buffers for reuse; glibc's allocator hands them back to the
/// kernel and pays page faults on every training step (measured in README, "Measured figures").
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::process::ExitCode;

use clap::Parser as _;

/// How a run ended; `main` alone turns it into the process exit code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExitStatus {
    /// 0: done.
    Success,
    /// 1: ran, but a check failed (a replay mismatch, a metric below its threshold).
    CheckFailed,
}

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(ExitStatus::Success) => ExitCode::SUCCESS,
        Ok(ExitStatus::CheckFailed) => ExitCode::from(1),
        Err(err) => {
            eprintln!("groundscope: {err:#}");
            ExitCode::from(2)
        }
    }
}
