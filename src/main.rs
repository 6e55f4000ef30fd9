//! The `groundscope` command line.

mod cli;

/// mimalloc keeps freed tensor buffers for reuse; glibc's allocator hands them back to the
/// kernel and pays page faults on every training step (measured in
/// docs/studies/performance-history.md).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::process::ExitCode;

use clap::error::ErrorKind;
use clap::{CommandFactory as _, FromArgMatches as _};
use groundscope::panics::panic_text;

/// How a run ended; `main` alone turns it into the process exit code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExitStatus {
    /// 0: done.
    Success,
    /// 1: ran, but a check failed (a replay mismatch, a metric below its threshold).
    CheckFailed,
    /// 2: bad input that the command has already reported, one line per file (`env verify`
    /// checks every file it is given before it ends).
    BadInput,
    /// 130: stopped by Ctrl-C (or SIGTERM, SIGHUP) before it finished: before its outputs
    /// were written, or (`train`) saved short of its `--frames`, or (`study exec`, `study
    /// run`) with a run left to resume; the command has said what it kept.
    Interrupted,
}

fn main() -> ExitCode {
    one_candle_thread_by_default();
    keep_freed_pages();
    file_size_limit_is_an_error();
    // `println!` panics when stdout is closed or full. Those panics are not bugs: they are
    // turned into ripgrep's behaviour (a broken pipe ends quietly with 0, a full disk is a
    // one-line error with 2) after unwinding, which removes any temporary output files.
    let default_hook = std::panic::take_hook();
    // tract panics when an allocation fails (a graph past docs/onnx.md#limits that asks for
    // more memory than there is): the ONNX runtime catches that and says so in one line.
    std::panic::set_hook(Box::new(move |info| {
        if stdout_failure(info.payload()).is_none() && allocation_failure(info.payload()).is_none()
        {
            default_hook(info);
        }
    }));
    match std::panic::catch_unwind(run) {
        Ok(code) => code,
        Err(payload) => match stdout_failure(payload.as_ref()) {
            Some(reason) if reason.contains("Broken pipe") => ExitCode::SUCCESS,
            Some(reason) => {
                eprintln!("groundscope: writing to standard output: {reason}");
                ExitCode::from(2)
            }
            None => match allocation_failure(payload.as_ref()) {
                Some(what) => {
                    eprintln!("groundscope: out of memory: {what}");
                    ExitCode::from(2)
                }
                None => ExitCode::from(101),
            },
        },
    }
}

/// The message of a panic raised by a failed allocation (tract's tensors), if it is one.
fn allocation_failure(payload: &(dyn std::any::Any + Send)) -> Option<String> {
    let text = panic_text(payload)?;
    text.starts_with("failed to allocate")
        .then(|| text.to_owned())
}

/// The I/O error of a panic raised by `print!` on a failing stdout, if it is one.
fn stdout_failure(payload: &(dyn std::any::Any + Send)) -> Option<String> {
    panic_text(payload)?
        .strip_prefix("failed printing to stdout: ")
        .map(str::to_owned)
}

fn run() -> ExitCode {
    let matches = match cli::Cli::command().try_get_matches() {
        Ok(m) => m,
        Err(err) => return usage_error(&err),
    };
    let args = match cli::Cli::from_arg_matches(&matches) {
        Ok(args) => args,
        Err(err) => return usage_error(&err),
    };
    match cli::run(args, &matches) {
        Ok(ExitStatus::Success) => ExitCode::SUCCESS,
        Ok(ExitStatus::CheckFailed) => ExitCode::from(1),
        Ok(ExitStatus::BadInput) => ExitCode::from(2),
        Ok(ExitStatus::Interrupted) => ExitCode::from(130),
        Err(err) => {
            eprintln!("groundscope: {err:#}");
            ExitCode::from(2)
        }
    }
}

/// Help and version go out as clap renders them; every other command-line error is one line
/// (clap's own message without its usage block), like every other bad input. The message is
/// clap's first paragraph joined into that line: its first line alone ends in a colon where
/// the missing arguments follow ("the following required arguments were not provided:",
/// then `--out <DIR>` on the next line), and a value's possible values sit below it too.
fn usage_error(err: &clap::Error) -> ExitCode {
    if !err.use_stderr() {
        let _ = err.print();
        return ExitCode::SUCCESS;
    }
    if err.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        // `groundscope env` alone: the subcommand list is the useful answer.
        let _ = err.print();
        return ExitCode::from(2);
    }
    // clap puts its "did you mean" in a tip below the first paragraph: kept in the one line.
    let suggested = [
        clap::error::ContextKind::SuggestedArg,
        clap::error::ContextKind::SuggestedSubcommand,
        clap::error::ContextKind::SuggestedValue,
    ]
    .into_iter()
    .find_map(|k| match err.get(k) {
        Some(clap::error::ContextValue::String(s)) => Some(s.clone()),
        // clap lists its candidates from the least to the most similar.
        Some(clap::error::ContextValue::Strings(v)) => v.last().cloned(),
        _ => None,
    });
    let hint = suggested.map_or_else(String::new, |s| format!("; did you mean {s}?"));
    eprintln!(
        "groundscope: {}{hint} (see --help)",
        usage_message(&err.render().to_string())
    );
    ExitCode::from(2)
}

/// Clap's rendered error as one line: its first paragraph (up to the first blank line), each
/// line trimmed, without the `error: ` prefix.
fn usage_message(rendered: &str) -> String {
    let lines: Vec<&str> = rendered
        .lines()
        .map(str::trim)
        .take_while(|l| !l.is_empty())
        .collect();
    let joined = lines.join(" ");
    let message = joined.strip_prefix("error: ").unwrap_or(&joined);
    if message.is_empty() {
        "invalid arguments".to_owned()
    } else {
        message.to_owned()
    }
}

/// groundscope parallelises explicitly (`eval --jobs`, `train --update-threads`, the app's
/// worker). candle's own threads — rayon for matmuls, a spinning barrier pool for large
/// element-wise ops — fight those workers for the cores (the default sweep took 71 s instead of
/// 31 s) and give nothing on this model's batch sizes, so both default to 1 unless the user
/// sets `RAYON_NUM_THREADS` / `CANDLE_NUM_THREADS`.
#[expect(
    unsafe_code,
    reason = "set_var before any other thread exists; candle reads these variables lazily"
)]
fn one_candle_thread_by_default() {
    for var in ["RAYON_NUM_THREADS", "CANDLE_NUM_THREADS"] {
        if std::env::var_os(var).is_none() {
            // SAFETY: the first statement of `main`, while this is the only thread.
            unsafe { std::env::set_var(var, "1") };
        }
    }
}

/// mimalloc's `mi_option_purge_delay` (its index in `mimalloc.h`'s `mi_option_e`, the same in
/// mimalloc 2 and 3; libmimalloc-sys names it only for version 2).
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// mimalloc hands pages it has not reused within a second back to the kernel, and a 2048-frame
/// training step frees and re-allocates tens of MB per op: the kernel then zeroes every page
/// again on first touch (`clear_page_erms`, 11% of a 2048-frame fwd+bwd profile). Keeping them
/// costs only the peak footprint, which the process reaches every step anyway. Measured in
/// docs/studies/performance-history.md (issue #16). `MIMALLOC_PURGE_DELAY` set by the user
/// still wins.
#[expect(unsafe_code, reason = "mi_option_set is an FFI call")]
fn keep_freed_pages() {
    if std::env::var_os("MIMALLOC_PURGE_DELAY").is_none() {
        // SAFETY: sets an option value of the allocator; any value is valid at any time.
        unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) };
    }
}

/// Under `ulimit -f` a write past the limit raises SIGXFSZ, whose default action kills the
/// process with temporary files left behind. Ignored, the write fails with EFBIG instead and
/// is reported like any other write error (one line, exit 2, nothing left over).
#[cfg(unix)]
#[expect(
    unsafe_code,
    reason = "signal() with SIG_IGN before any other thread exists"
)]
fn file_size_limit_is_an_error() {
    // SAFETY: ignoring a signal installs no handler code; called while single-threaded.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

#[cfg(not(unix))]
fn file_size_limit_is_an_error() {}

#[cfg(test)]
mod tests {
    use super::usage_message;

    #[test]
    fn a_usage_error_keeps_its_whole_first_paragraph() {
        let missing = "error: the following required arguments were not provided:\n  --out <DIR>\n  <FILE>...\n\nUsage: groundscope eval --out <DIR>\n\nFor more information, try '--help'.\n";
        assert_eq!(
            usage_message(missing),
            "the following required arguments were not provided: --out <DIR> <FILE>..."
        );
        let unexpected = "error: unexpected argument '--nope' found\n\n  tip: to pass '--nope' as a value, use '-- --nope'\n\nUsage: groundscope view\n";
        assert_eq!(
            usage_message(unexpected),
            "unexpected argument '--nope' found"
        );
        assert_eq!(usage_message(""), "invalid arguments");
    }
}
