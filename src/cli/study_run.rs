//! `groundscope study run`: a planned study on this machine's cores, a small scheduler of N
//! `study exec` processes at a time (each run one process: its steps run inside it), with one
//! progress line; and `groundscope bench study`, the aggregate training speed of 1 and N
//! concurrent runs.
//!
//! A child's output goes to an unnamed temporary file, never to a pipe left unread (a full
//! one would stop a chatty child for good); a stop is passed on with `kill(2)`, once; a run's
//! progress is its `log.csv` read by column name ([`groundscope::run::last_row`]); and how a
//! run ended is what its exec says in its outcome file ([`ExecOutcome`]), not its exit status
//! alone.

use std::fmt::Write as _;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Args;
use groundscope::study::{ExecOutcome, FAILED_FILE, Failed, LOG_FILE, PlannedRun, RunState};

use crate::ExitStatus;
use crate::cli::stop::Stop;

/// `groundscope study run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The study directory (`study plan --out`).
    pub study: PathBuf,
    /// Runs at a time [default: the cores divided by a run's training threads].
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub jobs: Option<i64>,
    /// No progress line; one line per run as it ends.
    #[arg(long)]
    pub quiet: bool,
}

/// How often the runner looks at its runs.
const POLL: Duration = Duration::from_millis(200);

/// One `study exec` the runner started.
struct Running {
    run: PlannedRun,
    child: Child,
    /// What the exec printed (its standard output and error), shown when the run fails
    /// ([`spawn_captured`]).
    output: File,
    /// Where the exec writes how the run ended.
    outcome: PathBuf,
    /// Whether this runner has passed its stop on to the exec.
    signalled: bool,
}

/// The most of a failed exec's output the runner reads back (its end).
const OUTPUT_TAIL_BYTES: u64 = 64 * 1024;

/// Lines of a failed run's output (and of its `study.log`) the runner shows.
const TAIL_LINES: usize = 5;

/// Counts for the progress line.
#[derive(Default)]
struct Tally {
    done: usize,
    failed: Vec<String>,
    /// Runs stopped by a signal that this runner did not send (to the exec alone): neither
    /// done nor failed, they resume on the next run.
    stopped: Vec<String>,
    elsewhere: usize,
}

/// The cores of this machine.
pub(super) fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

/// A count flag's value: at least 1, or the flag's own one-line refusal (`--jobs -1: must be
/// at least 1`).
pub(super) fn count(flag: &str, n: i64) -> anyhow::Result<usize> {
    if n < 1 {
        anyhow::bail!("{flag} {n}: must be at least 1");
    }
    usize::try_from(n).map_err(|_| anyhow::anyhow!("{flag} {n}: too large"))
}

pub(super) fn run(args: &RunArgs) -> anyhow::Result<ExitStatus> {
    let study = &args.study;
    let jobs = args.jobs.map(|n| count("--jobs", n)).transpose()?;
    let manifest = super::study_legacy::read_manifest(study, true)?;
    // A hand-edited run (a name outside runs/, steps that do not hash to their hash) is
    // refused before any run starts.
    manifest.check_runs(&study.join("manifest.json"))?;
    let threads = manifest.runs.iter().map(|r| r.threads).max().unwrap_or(1);
    let jobs = jobs.unwrap_or_else(|| (cores() / threads).max(1));
    let mut tally = Tally::default();
    let mut queue: std::collections::VecDeque<PlannedRun> = manifest
        .runs
        .iter()
        .filter(|r| {
            let done = RunState::of(study, r) == RunState::Done;
            tally.done += usize::from(done);
            !done
        })
        .cloned()
        .collect();
    let total = manifest.runs.len();
    let stop = Stop::install();
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new_spinner()
    };
    let exe = std::env::current_exe().context("finding this binary")?;
    let outcomes = tempfile::tempdir().context("creating a temporary directory")?;
    let mut running: Vec<Running> = Vec::new();
    println!(
        "study {}: {} of {total} runs to do, {jobs} at a time",
        manifest.name,
        queue.len()
    );
    loop {
        while running.len() < jobs && !stop.requested() {
            let Some(run) = queue.pop_front() else { break };
            // Names are plain (checked above): a file name of the directory.
            let outcome = outcomes.path().join(format!("{}.json", run.name));
            let (child, output) = spawn_captured(
                Command::new(&exe)
                    .args(["study", "exec"])
                    .arg(study)
                    .arg(&run.name)
                    .arg("--outcome")
                    .arg(&outcome),
            )
            .with_context(|| format!("starting run {}", run.name))?;
            running.push(Running {
                run,
                child,
                output,
                outcome,
                signalled: false,
            });
        }
        if running.is_empty() {
            break;
        }
        std::thread::sleep(POLL);
        let mut i = 0;
        while i < running.len() {
            if let Some(status) = running[i].child.try_wait()? {
                let mut r = running.swap_remove(i);
                ended(study, &mut r, status, stop.requested(), &mut tally, &bar);
            } else {
                i += 1;
            }
        }
        if stop.requested() {
            // A Ctrl-C reaches the runs too (one process group); a SIGTERM sent to the runner
            // alone is passed on, once, so that every training saves before it ends.
            for r in running.iter_mut().filter(|r| !r.signalled) {
                interrupt(&mut r.child);
                r.signalled = true;
            }
        }
        bar.set_message(format!(
            "{}/{total} done · {} running · {} failed · {:.0} frames/s",
            tally.done,
            running.len(),
            tally.failed.len(),
            running
                .iter()
                .map(|r| latest_fps(&r.run.dir(study)))
                .sum::<f64>()
        ));
        bar.tick();
    }
    bar.finish_and_clear();
    if stop.requested() {
        eprintln!(
            "groundscope: interrupted: {} of {total} runs done; every started run saved its training; run `groundscope study run {}` again to resume",
            tally.done,
            study.display()
        );
        return Ok(ExitStatus::Interrupted);
    }
    Ok(summary(&manifest.name, total, &tally, study))
}

/// The runner's last lines and exit status: 1 where a run failed (named), else 130 where a
/// run was stopped by a signal it did not send (named: they resume on the next run), else 0.
fn summary(name: &str, total: usize, tally: &Tally, study: &Path) -> ExitStatus {
    let mut also = String::new();
    if !tally.stopped.is_empty() {
        let _ = write!(also, ", {} stopped", tally.stopped.len());
    }
    if tally.elsewhere > 0 {
        let _ = write!(also, ", {} running elsewhere", tally.elsewhere);
    }
    println!(
        "study {name}: {} of {total} runs done, {} failed{also}",
        tally.done,
        tally.failed.len(),
    );
    if !tally.stopped.is_empty() {
        eprintln!(
            "stopped runs (by a signal sent to them alone; not finished): {}; run `groundscope study run {}` again to resume them",
            tally.stopped.join(", "),
            study.display()
        );
    }
    if tally.failed.is_empty() {
        return if tally.stopped.is_empty() {
            ExitStatus::Success
        } else {
            ExitStatus::Interrupted
        };
    }
    eprintln!("failed runs: {}", tally.failed.join(", "));
    ExitStatus::CheckFailed
}

/// What the end of a run's exec means to the runner.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Verdict {
    /// Every step has ended in order.
    Done,
    /// Another process holds the run (named): left alone.
    Elsewhere(String),
    /// Stopped by this runner's own stop: it resumes on the next run.
    Paused,
    /// Stopped by a signal this runner did not send (to the exec alone): neither done nor
    /// failed, it resumes on the next run.
    Stopped,
    /// Failed, and how (`exit 1`, `killed by a signal`, an exit 0 that said nothing).
    Failed(String),
}

/// How a run ended, from its exec's exit `code` (`None`: killed by a signal) and the outcome
/// it wrote (`Ok(None)`: none; `Err`: one that does not read), `stopping` when this runner
/// had passed its stop on. The outcome decides where there is one; without one, an exec that
/// ended 130 (or, under a stop, by a signal) was stopped, and any other is a failure — an
/// exec that ends with 0 and says nothing of the run too, named as such.
fn verdict(
    code: Option<i32>,
    outcome: Result<Option<ExecOutcome>, String>,
    stopping: bool,
) -> Verdict {
    let how = |code: Option<i32>| {
        code.map_or_else(|| "killed by a signal".to_owned(), |c| format!("exit {c}"))
    };
    match outcome {
        Ok(Some(ExecOutcome::Done)) => Verdict::Done,
        Ok(Some(ExecOutcome::Elsewhere { holder })) => Verdict::Elsewhere(holder),
        Ok(Some(ExecOutcome::Stopped { .. })) if stopping => Verdict::Paused,
        Ok(Some(ExecOutcome::Stopped { .. })) => Verdict::Stopped,
        Ok(Some(ExecOutcome::Failed { .. })) => Verdict::Failed(how(code)),
        _ if stopping && matches!(code, Some(130) | None) => Verdict::Paused,
        _ if code == Some(130) => Verdict::Stopped,
        Ok(None) if code == Some(0) => Verdict::Failed(
            "exit 0 without an outcome: its exec said nothing of how the run ended".to_owned(),
        ),
        Err(why) if code == Some(0) => {
            Verdict::Failed(format!("exit 0 with an outcome that does not read: {why}"))
        }
        Ok(None) | Err(_) => Verdict::Failed(how(code)),
    }
}

/// The outcome an exec wrote at `path`: `Ok(None)` where it wrote none.
fn read_outcome(path: &Path) -> Result<Option<ExecOutcome>, String> {
    match std::fs::read_to_string(path) {
        Ok(text) => serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| groundscope::study::one_line(&format!("{}: {e}", path.display()))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

/// Counts a run that ended ([`verdict`]) and says so above the progress line. A failed run's
/// last lines are shown: the exec's error, and the end of its `study.log` where a step failed.
fn ended(
    study: &Path,
    r: &mut Running,
    status: std::process::ExitStatus,
    stopping: bool,
    tally: &mut Tally,
    bar: &indicatif::ProgressBar,
) {
    let name = &r.run.name;
    match verdict(status.code(), read_outcome(&r.outcome), stopping) {
        Verdict::Done => {
            tally.done += 1;
            say(bar, format!("{name}: done"));
        }
        Verdict::Elsewhere(holder) => {
            tally.elsewhere += 1;
            say(
                bar,
                format!("{name}: running elsewhere ({holder}); left alone"),
            );
        }
        Verdict::Paused => say(bar, format!("{name}: stopped; it resumes on the next run")),
        Verdict::Stopped => {
            tally.stopped.push(name.clone());
            say(
                bar,
                format!(
                    "{name}: stopped by a signal before it finished (exit 130); it resumes on the next run"
                ),
            );
        }
        Verdict::Failed(how) => {
            tally.failed.push(name.clone());
            let text = failure_text(study, r, &how);
            say(bar, text);
        }
    }
}

/// What the runner says of failed run `r`: how it failed, the end of its exec's output, and
/// where a step failed, that step and the end of its `study.log`.
fn failure_text(study: &Path, r: &mut Running, how: &str) -> String {
    let dir = r.run.dir(study);
    let mut text = format!("{}: failed ({how})", r.run.name);
    let output = output_of(&mut r.output);
    for line in tail(&output, TAIL_LINES) {
        text.push_str("\n  ");
        text.push_str(line);
    }
    let failed = dir.join(FAILED_FILE);
    if failed.is_file() {
        let log_path = dir.join(LOG_FILE);
        let record = std::fs::read_to_string(&failed).unwrap_or_default();
        let said = match serde_json::from_str::<Failed>(&record) {
            Ok(f) => format!("{} failed, exit {}", f.step, f.exit),
            // A record of an earlier version's, shown as it is.
            Err(_) => groundscope::study::one_line(record.trim()),
        };
        let _ = write!(
            text,
            "\n  {} ({said}); the end of {}:",
            failed.display(),
            log_path.display()
        );
        let log = std::fs::read_to_string(&log_path).unwrap_or_default();
        for line in tail(&log, TAIL_LINES) {
            text.push_str("\n    ");
            text.push_str(line);
        }
    }
    text
}

/// The end of what an exec printed (at most its last [`OUTPUT_TAIL_BYTES`]); empty where it
/// cannot be read back.
fn output_of(file: &mut File) -> String {
    use std::io::{Read as _, Seek as _, SeekFrom};
    let len = file.metadata().map_or(0, |m| m.len());
    let mut bytes = Vec::new();
    if file
        .seek(SeekFrom::Start(len.saturating_sub(OUTPUT_TAIL_BYTES)))
        .is_ok()
    {
        let _ = file.read_to_end(&mut bytes);
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

/// The last `n` non-empty lines of `text`, in order.
fn tail(text: &str, n: usize) -> Vec<&str> {
    let mut lines: Vec<&str> = text
        .lines()
        .rev()
        .filter(|l| !l.trim().is_empty())
        .take(n)
        .collect();
    lines.reverse();
    lines
}

/// A line above the progress line, or on its own where there is none (`--quiet`).
fn say(bar: &indicatif::ProgressBar, line: String) {
    if bar.is_hidden() {
        println!("{line}");
    } else {
        bar.println(line);
    }
}

/// The frames/s of a run's last logged update (0 before its first).
fn latest_fps(run: &Path) -> f64 {
    groundscope::run::last_row(&run.join("log.csv")).map_or(0.0, |row| row.fps)
}

/// Starts `cmd` with no input and its standard output and error in one unnamed temporary
/// file, returned for reading back. Never a pipe: a pipe nobody reads fills up (64 KiB) and
/// stops a chatty child for good, and the runner reads a child's output only once it ends.
fn spawn_captured(cmd: &mut Command) -> anyhow::Result<(Child, File)> {
    let output = tempfile::tempfile().context("creating a temporary file")?;
    let child = cmd
        .stdin(Stdio::null())
        .stdout(output.try_clone()?)
        .stderr(output.try_clone()?)
        .spawn()?;
    Ok((child, output))
}

/// Passes a stop on to `child` as Ctrl-C would (SIGINT).
#[cfg(unix)]
#[expect(
    unsafe_code,
    reason = "kill(2) of a child process this process has not reaped"
)]
fn interrupt(child: &mut Child) {
    let Ok(pid) = libc::pid_t::try_from(child.id()) else {
        return;
    };
    // SAFETY: kill takes plain integers. The child has not been waited for (the poll found it
    // running), so its pid is still its own, never another process's.
    unsafe {
        libc::kill(pid, libc::SIGINT);
    }
}

/// Elsewhere than on Unix there is no SIGINT to pass on: the child is ended.
#[cfg(not(unix))]
fn interrupt(child: &mut Child) {
    let _ = child.kill();
}

/// The peak resident memory of process `pid` so far, in MiB (Linux's `VmHWM`; 0 elsewhere).
fn peak_rss_mib(pid: u32) -> f64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

/// `groundscope bench study`: `runs` trainings of the paper's recipe (one thread each, as a
/// study's runs), first one alone and then all at once, each `frames` long: the aggregate
/// frames/s of each, their ratio, and each run's peak memory. Prints JSON lines.
pub(super) fn bench_study(frames: u64, runs: usize) -> anyhow::Result<ExitStatus> {
    if runs == 0 {
        anyhow::bail!("--runs 0: must be at least 1");
    }
    if frames == 0 {
        anyhow::bail!("--frames 0: must be at least 1");
    }
    let tmp = tempfile::tempdir().context("creating a temporary directory")?;
    let exe = std::env::current_exe().context("finding this binary")?;
    let mut rates = Vec::new();
    for n in [1, runs] {
        let start = Instant::now();
        let mut children: Vec<(Child, File, f64)> = (0..n)
            .map(|i| {
                let out = tmp.path().join(format!("n{n}-run{i}"));
                spawn_captured(
                    Command::new(&exe)
                        .arg("train")
                        .args(["--frames", &frames.to_string(), "--seed", &i.to_string()])
                        .args([
                            "--eval-interval",
                            "0",
                            "--save-interval",
                            "1000000",
                            "--quiet",
                        ])
                        .arg("--out")
                        .arg(&out),
                )
                .map(|(c, output)| (c, output, 0.0))
                .context("starting a training")
            })
            .collect::<anyhow::Result<_>>()?;
        let mut left = n;
        while left > 0 {
            std::thread::sleep(Duration::from_millis(50));
            left = 0;
            for (c, _, peak) in &mut children {
                if c.try_wait()?.is_none() {
                    *peak = peak_rss_mib(c.id()).max(*peak);
                    left += 1;
                }
            }
        }
        let secs = start.elapsed().as_secs_f64();
        for (c, output, _) in &mut children {
            if !c.wait()?.success() {
                let err = output_of(output);
                anyhow::bail!("a training failed: {}", tail(&err, TAIL_LINES).join(" / "));
            }
        }
        // Whole updates of 2,048 frames: what each run trained.
        let per_run = frames.div_ceil(2048) * 2048;
        let fps = (per_run * n as u64) as f64 / secs;
        let peaks: Vec<f64> = children
            .iter()
            .map(|(_, _, p)| (p * 10.0).round() / 10.0)
            .collect();
        println!(
            "{}",
            serde_json::json!({"bench": "study", "runs": n, "frames_per_run": per_run,
                "seconds": secs, "frames_per_sec": fps.round(), "peak_rss_mib": peaks,
                "cores": cores()})
        );
        rates.push(fps);
    }
    if runs > 1 {
        println!(
            "{}",
            serde_json::json!({"bench": "study", "runs": runs,
                "speedup_over_one": (rates[1] / rates[0] * 100.0).round() / 100.0})
        );
    }
    Ok(ExitStatus::Success)
}

#[cfg(test)]
mod tests {
    use super::*;
    use groundscope::study::Step;

    #[test]
    fn an_exec_that_ends_with_0_and_says_nothing_is_a_failed_run() {
        let failed = |v: Verdict| matches!(v, Verdict::Failed(_));
        assert!(failed(verdict(Some(0), Ok(None), false)));
        let Verdict::Failed(how) = verdict(Some(0), Ok(None), false) else {
            unreachable!()
        };
        assert!(how.contains("without an outcome"), "{how}");
        assert!(failed(verdict(Some(0), Err("garbled".into()), false)));
        // What the outcome says decides, not the status alone.
        let holder = ExecOutcome::Elsewhere {
            holder: "pid 7".into(),
        };
        assert_eq!(
            verdict(Some(0), Ok(Some(holder)), false),
            Verdict::Elsewhere("pid 7".into())
        );
        assert_eq!(
            verdict(Some(0), Ok(Some(ExecOutcome::Done)), false),
            Verdict::Done
        );
        let stopped = || Ok(Some(ExecOutcome::Stopped { step: Step::Eval }));
        assert_eq!(verdict(Some(130), stopped(), false), Verdict::Stopped);
        assert_eq!(verdict(Some(130), stopped(), true), Verdict::Paused);
        let step_failed = ExecOutcome::Failed {
            step: Step::Train,
            exit: 2,
            error: "no".into(),
        };
        assert_eq!(
            verdict(Some(1), Ok(Some(step_failed)), false),
            Verdict::Failed("exit 1".into())
        );
        // Without an outcome: an exec refused (2), stopped (130) or killed.
        assert_eq!(
            verdict(Some(2), Ok(None), false),
            Verdict::Failed("exit 2".into())
        );
        assert_eq!(verdict(Some(130), Ok(None), false), Verdict::Stopped);
        assert_eq!(verdict(None, Ok(None), true), Verdict::Paused);
        assert_eq!(
            verdict(None, Ok(None), false),
            Verdict::Failed("killed by a signal".into())
        );
    }

    #[test]
    fn a_chatty_child_never_blocks_on_its_output() {
        // 4 MB on each stream, far past what a pipe holds, and nobody reading meanwhile.
        let (mut child, mut output) = spawn_captured(Command::new("sh").args([
            "-c",
            "head -c 4000000 /dev/zero | tr '\\0' x; head -c 4000000 /dev/zero >&2; echo; echo the end >&2",
        ]))
        .unwrap();
        let deadline = Instant::now() + Duration::from_mins(2);
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if Instant::now() > deadline {
                let _ = child.kill();
                panic!("the child is stuck on its output");
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        assert!(status.success());
        assert_eq!(tail(&output_of(&mut output), 1), ["the end"]);
    }
}
