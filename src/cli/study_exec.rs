//! `groundscope study exec STUDY NAME`: one run's steps — its training, resumed where it
//! stopped, then its evaluation and, where the spec asks, a faithfulness run — in this
//! process, under the run directory's own lock (`groundscope::run::RunDir::claim`): a second
//! exec of the run, or a `train` started by hand in its directory, finds it held and leaves
//! the run alone. What the steps print goes to the run's `study.log`; how the attempt ended
//! is told to whoever started it (`--outcome`), and kept in the run's `study-done.json` or
//! `study-failed.json`.

use std::fs::File;
use std::path::Path;
use std::time::Instant;

use anyhow::Context as _;
use groundscope::files::write_output;
use groundscope::run::{RunDir, RunError};
use groundscope::study::{
    DONE_FILE, Done, ExecOutcome, FAILED_FILE, Failed, LOG_FILE, PlannedRun, Step, one_line,
};

use crate::ExitStatus;
use crate::cli::stop::Stop;

/// Runs run `name` of `study`; `outcome`: where to write how it ended ([`ExecOutcome`]), for a
/// runner. Bad input (a manifest it refuses, a run directory it cannot make) is an error, and
/// no outcome is written.
pub(super) fn exec(study: &Path, name: &str, outcome: Option<&Path>) -> anyhow::Result<ExitStatus> {
    let manifest = super::study_legacy::read_manifest(study, true)?;
    let run = manifest.run(name)?;
    // A hand-edited run is refused before anything of it runs: a name that is not a plain
    // name would put its directory outside runs/, edited steps would run unchecked.
    run.check(&study.join("manifest.json"))?;
    let outcome = outcome
        .map(std::path::absolute)
        .transpose()
        .context("--outcome")?;
    // The steps run in the study directory, as they always have: the reports name the
    // checkpoint by its place in the study (`runs/NAME`), wherever the line is run from.
    std::env::set_current_dir(study).with_context(|| format!("entering {}", study.display()))?;
    let dir = run.dir(Path::new(""));
    let shown = study.join(&dir);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", shown.display()))?;
    let ended = attempt(run, &dir, &shown)?;
    if let Some(path) = &outcome {
        let json = serde_json::to_string(&ended)?;
        write_output(path, json.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(match ended {
        ExecOutcome::Done | ExecOutcome::Elsewhere { .. } => ExitStatus::Success,
        ExecOutcome::Stopped { .. } => ExitStatus::Interrupted,
        ExecOutcome::Failed { .. } => ExitStatus::CheckFailed,
    })
}

/// One attempt at `run` in `dir` (shown as `shown`): its lock taken, then its steps in order,
/// each until it fails or a stop ends it.
fn attempt(run: &PlannedRun, dir: &Path, shown: &Path) -> anyhow::Result<ExecOutcome> {
    let name = &run.name;
    let claim = match RunDir::claim(dir) {
        Ok(claim) => claim,
        Err(RunError::Held { pid, .. }) => {
            let holder = if pid.is_empty() {
                "another process".to_owned()
            } else {
                format!("pid {pid}")
            };
            println!("{name}: running elsewhere (its lock is held by {holder}); left alone");
            return Ok(ExecOutcome::Elsewhere { holder });
        }
        Err(e) => return Err(e).with_context(|| format!("locking {}", shown.display())),
    };
    if dir.join(DONE_FILE).is_file() {
        println!("{name}: done");
        return Ok(ExecOutcome::Done);
    }
    let _ = std::fs::remove_file(dir.join(FAILED_FILE));
    let log_path = dir.join(LOG_FILE);
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .with_context(|| format!("opening {}", shown.join(LOG_FILE).display()))?;
    let stop = Stop::install();
    let start = Instant::now();
    // The run's lock, held from here to the end: the training hands it back when it ends in
    // order, so that its evaluation runs under it too.
    let mut held = Some(claim);
    for step in run.steps() {
        let ended = run_step(run, dir, step, &mut held, &log, &stop);
        if stop.requested() || matches!(ended, Ok(ExitStatus::Interrupted)) {
            eprintln!(
                "{name}: {step} was stopped by a signal before it ended: the run is not done; run the line again to resume it"
            );
            return Ok(ExecOutcome::Stopped { step });
        }
        let (exit, error) = match ended {
            Ok(ExitStatus::Success) => continue,
            Ok(ExitStatus::CheckFailed) => (1, "a check failed".to_owned()),
            Ok(_) => (2, "bad input".to_owned()),
            Err(e) => (2, one_line(&format!("{e:#}"))),
        };
        return failed(dir, shown, name, Failed { step, exit, error }, held);
    }
    let done = Done {
        seconds: start.elapsed().as_secs_f64(),
    };
    write_output(
        &dir.join(DONE_FILE),
        serde_json::to_string(&done)?.as_bytes(),
    )
    .with_context(|| format!("writing {}", shown.join(DONE_FILE).display()))?;
    println!("{name}: done in {:.0} s", done.seconds);
    drop(held);
    Ok(ExecOutcome::Done)
}

/// Records `failure` of run `name` (`study-failed.json`) and says so, naming the log. It is
/// recorded under the run's lock: still `held` after an evaluation, taken again after a
/// training (whose end let it go); an attempt that took it meanwhile has the run, and its own
/// record to write.
fn failed(
    dir: &Path,
    shown: &Path,
    name: &str,
    failure: Failed,
    held: Option<RunDir>,
) -> anyhow::Result<ExecOutcome> {
    let lock = match held {
        Some(lock) => Some(lock),
        None => match RunDir::claim(dir) {
            Ok(lock) => Some(lock),
            Err(RunError::Held { .. }) => None,
            Err(e) => return Err(e).with_context(|| format!("locking {}", shown.display())),
        },
    };
    if lock.is_some() {
        write_output(
            &dir.join(FAILED_FILE),
            serde_json::to_string(&failure)?.as_bytes(),
        )
        .with_context(|| format!("writing {}", shown.join(FAILED_FILE).display()))?;
    }
    drop(lock);
    let Failed { step, exit, error } = failure;
    eprintln!(
        "{name}: {step} failed (exit {exit}): {error}; its output: {}",
        shown.join(LOG_FILE).display()
    );
    Ok(ExecOutcome::Failed { step, exit, error })
}

/// Runs `step` of `run` (in `dir`) in this process, stopped by `stop`, what it prints going
/// into `log` behind a line naming it (`== groundscope train`, `--resume` for a training that
/// goes on), and an error it ends with too, as the command would print it.
fn run_step(
    run: &PlannedRun,
    dir: &Path,
    step: Step,
    held: &mut Option<RunDir>,
    log: &File,
    stop: &Stop,
) -> anyhow::Result<ExitStatus> {
    use std::io::Write as _;
    let resume = step == Step::Train && held.as_ref().is_some_and(RunDir::holds_run);
    let mut out = log;
    writeln!(
        out,
        "== groundscope {step}{}",
        if resume { " --resume" } else { "" }
    )?;
    let _redirected = Redirected::to(log)?;
    let ended = match step {
        Step::Train => match held.take() {
            Some(claim) => {
                super::train::study_train(&run.train, claim, stop).map(|(status, claim)| {
                    *held = Some(claim);
                    status
                })
            }
            None => Err(anyhow::anyhow!("the run's lock is not held")),
        },
        Step::Eval => super::eval::run_with(&super::study_steps::eval_args(&run.eval, dir), stop),
        Step::Faithfulness => match &run.faithfulness {
            Some(f) => {
                super::faithfulness::run_with(&super::study_steps::faithfulness_args(f, dir), stop)
            }
            None => Ok(ExitStatus::Success),
        },
    };
    if let Err(e) = &ended {
        eprintln!("groundscope: {e:#}");
    }
    ended
}

/// This process's standard output and error sent to a run's log while a step runs, restored
/// when dropped: the steps run in this process and print as their commands do (`println!`,
/// `eprintln!`), and what they print belongs in `study.log`, beside the run's files, whichever
/// engine runs the line. (Elsewhere than on Unix the output stays where it is.)
struct Redirected {
    #[cfg(unix)]
    saved: [std::os::fd::OwnedFd; 2],
}

impl Redirected {
    /// Points standard output and error at `log`.
    #[cfg(unix)]
    fn to(log: &File) -> anyhow::Result<Self> {
        use std::os::fd::AsFd as _;
        flush_stdout();
        let saved = [
            std::io::stdout().as_fd().try_clone_to_owned()?,
            std::io::stderr().as_fd().try_clone_to_owned()?,
        ];
        // Made first, so that a failure below restores what was pointed already.
        let redirected = Self { saved };
        for fd in [1, 2] {
            point(log.as_fd(), fd).context("sending the step's output to study.log")?;
        }
        Ok(redirected)
    }

    #[cfg(not(unix))]
    fn to(_log: &File) -> anyhow::Result<Self> {
        Ok(Self {})
    }
}

impl Drop for Redirected {
    fn drop(&mut self) {
        flush_stdout();
        #[cfg(unix)]
        {
            use std::os::fd::AsFd as _;
            for (saved, fd) in self.saved.iter().zip([1, 2]) {
                let _ = point(saved.as_fd(), fd);
            }
        }
    }
}

/// Writes out what `println!` holds back, before its descriptor is pointed elsewhere.
fn flush_stdout() {
    use std::io::Write as _;
    let _ = std::io::stdout().flush();
}

/// Makes descriptor `to` (1 or 2) a duplicate of `from`.
#[cfg(unix)]
#[expect(unsafe_code, reason = "dup2(2) on descriptors this process holds open")]
fn point(from: std::os::fd::BorrowedFd<'_>, to: std::os::fd::RawFd) -> std::io::Result<()> {
    use std::os::fd::AsRawFd as _;
    // SAFETY: `from` is open for as long as it is borrowed, and `to` is standard output or
    // error, which std's handles write to by number; dup2 replaces it atomically.
    if unsafe { libc::dup2(from.as_raw_fd(), to) } < 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}
