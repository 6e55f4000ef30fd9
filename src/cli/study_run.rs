//! `groundscope study run`: a planned study on this machine's cores, N `study exec` processes
//! at a time, with one progress line; and `groundscope bench study`, the aggregate training
//! speed of 1 and N concurrent runs.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Args;
use groundscope::study::{DONE_FILE, FAILED_FILE, LOG_FILE, Manifest, PlannedRun, RunState};

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
    /// What the exec printed (its standard output and error), in an unnamed temporary file:
    /// shown when the run fails, and never a pipe left unread (a full one would stop the exec).
    output: std::fs::File,
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
    /// Runs stopped by a signal that this runner did not send (to the exec or its step
    /// alone): neither done nor failed, they resume on the next run.
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
    let manifest = Manifest::read(study)?;
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
    let mut running: Vec<Running> = Vec::new();
    println!(
        "study {}: {} of {total} runs to do, {jobs} at a time",
        manifest.name,
        queue.len()
    );
    loop {
        while running.len() < jobs && !stop.requested() {
            let Some(run) = queue.pop_front() else { break };
            let output = tempfile::tempfile().context("creating a temporary file")?;
            let child = Command::new(&exe)
                .args(["study", "exec"])
                .arg(study)
                .arg(&run.name)
                .stdin(Stdio::null())
                .stdout(output.try_clone()?)
                .stderr(output.try_clone()?)
                .spawn()
                .with_context(|| format!("starting run {}", run.name))?;
            running.push(Running { run, child, output });
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
            // alone is passed on, so that every training saves before it ends.
            for r in &running {
                let _ = Command::new("kill")
                    .args(["-INT", &r.child.id().to_string()])
                    .status();
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

/// Counts a run that ended and says so above the progress line. A run whose exec ended
/// with a non-zero status is a failed run (its last lines are shown: the exec's error, and
/// the end of its `study.log` where a step failed), except a stopped one, which resumes on
/// the next run: one that this runner stopped (`stopping`: it sent the stop, and the run
/// ended interrupted, 130, or by a signal), or whose exec ended 130 all the same (a signal
/// sent to the exec or its step alone stopped it before it finished).
fn ended(
    study: &Path,
    r: &mut Running,
    status: std::process::ExitStatus,
    stopping: bool,
    tally: &mut Tally,
    bar: &indicatif::ProgressBar,
) {
    let dir = r.run.dir(study);
    let name = &r.run.name;
    if dir.join(DONE_FILE).is_file() {
        tally.done += 1;
        say(bar, format!("{name}: done"));
    } else if status.success() {
        // Its lock was held: another runner (or engine) has it.
        tally.elsewhere += 1;
        say(bar, format!("{name}: running elsewhere; left alone"));
    } else if stopping && matches!(status.code(), Some(130) | None) {
        say(bar, format!("{name}: stopped; it resumes on the next run"));
    } else if status.code() == Some(130) {
        tally.stopped.push(name.clone());
        say(
            bar,
            format!(
                "{name}: stopped by a signal before it finished (exit 130); it resumes on the next run"
            ),
        );
    } else {
        tally.failed.push(name.clone());
        let how = status
            .code()
            .map_or_else(|| "killed by a signal".to_owned(), |c| format!("exit {c}"));
        let mut text = format!("{name}: failed ({how})");
        let output = output_of(&mut r.output);
        for line in tail(&output, TAIL_LINES) {
            text.push_str("\n  ");
            text.push_str(line);
        }
        let failed = dir.join(FAILED_FILE);
        if failed.is_file() {
            let log_path = dir.join(LOG_FILE);
            let _ = write!(
                text,
                "\n  {} ({}); the end of {}:",
                failed.display(),
                std::fs::read_to_string(&failed).unwrap_or_default().trim(),
                log_path.display()
            );
            let log = std::fs::read_to_string(&log_path).unwrap_or_default();
            for line in tail(&log, TAIL_LINES) {
                text.push_str("\n    ");
                text.push_str(line);
            }
        }
        say(bar, text);
    }
}

/// The end of what an exec printed (at most its last [`OUTPUT_TAIL_BYTES`]); empty where it
/// cannot be read back.
fn output_of(file: &mut std::fs::File) -> String {
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
    std::fs::read_to_string(run.join("log.csv"))
        .ok()
        .and_then(|t| {
            t.lines()
                .skip(1)
                .last()
                .and_then(|l| l.split(',').nth(2).and_then(|v| v.parse().ok()))
        })
        .unwrap_or(0.0)
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
        let mut children: Vec<(Child, f64)> = (0..n)
            .map(|i| {
                let out = tmp.path().join(format!("n{n}-run{i}"));
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
                    .arg(&out)
                    .stdin(Stdio::null())
                    .stdout(Stdio::null())
                    .stderr(Stdio::piped())
                    .spawn()
                    .map(|c| (c, 0.0))
                    .context("starting a training")
            })
            .collect::<anyhow::Result<_>>()?;
        let mut left = n;
        while left > 0 {
            std::thread::sleep(Duration::from_millis(50));
            left = 0;
            for (c, peak) in &mut children {
                if c.try_wait()?.is_none() {
                    *peak = peak_rss_mib(c.id()).max(*peak);
                    left += 1;
                }
            }
        }
        let secs = start.elapsed().as_secs_f64();
        for (c, _) in &mut children {
            if !c.wait()?.success() {
                let mut err = String::new();
                if let Some(e) = c.stderr.as_mut() {
                    std::io::Read::read_to_string(e, &mut err)?;
                }
                anyhow::bail!("a training failed: {}", err.trim());
            }
        }
        // Whole updates of 2,048 frames: what each run trained.
        let per_run = frames.div_ceil(2048) * 2048;
        let fps = (per_run * n as u64) as f64 / secs;
        let peaks: Vec<f64> = children
            .iter()
            .map(|(_, p)| (p * 10.0).round() / 10.0)
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
