//! `groundscope study plan | run | exec | collect`: a seeds × recipes × levels grid planned
//! into command lines (`groundscope::study`), run here N at a time (`study_run.rs`), on Slurm
//! or on Ray, and collected from the runs' own reports.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::Context as _;
use clap::{Parser, Subcommand};
use groundscope::files::{read_regular_to_string, write_output};
use groundscope::study::collect::collect;
use groundscope::study::{
    DONE_FILE, FAILED_FILE, LOCK_FILE, LOG_FILE, Manifest, PlannedRun, RunState, SLURM_LOGS,
    StudySpec, check_replan, one_line,
};

use crate::ExitStatus;
use crate::cli::stop::Stop;

/// `groundscope study`.
#[derive(Debug, Subcommand)]
pub enum StudyCommand {
    /// Plan a study from a TOML spec (recipes × level sets × seeds): writes commands.txt (one
    /// line per run), manifest.json, slurm.sbatch and ray_driver.py into --out. Planning the
    /// same spec again changes nothing; a spec may add runs, never change one.
    #[command(
        after_long_help = "EXAMPLES:\n  groundscope study plan experiments/paper_seeds/study.toml --out studies/paper\n  groundscope study run studies/paper --jobs 2\n  sbatch studies/paper/slurm.sbatch\n  python studies/paper/ray_driver.py --address auto\n  groundscope study collect studies/paper"
    )]
    Plan {
        /// The spec (docs/studies.md#the-spec).
        #[arg(value_name = "SPEC.toml")]
        spec: PathBuf,
        /// The study directory.
        #[arg(long, value_name = "STUDY")]
        out: PathBuf,
    },
    /// Run a planned study on this machine, N runs at a time: finished runs are skipped,
    /// killed ones resume; one progress line; Ctrl-C stops every run at its next update,
    /// saved.
    Run(super::study_run::RunArgs),
    /// Run one run's steps — train (resumed where it was killed), eval, faithfulness — into
    /// STUDY/runs/NAME: what each line of commands.txt does. A run that is running elsewhere
    /// (its lock held) or finished is left alone.
    Exec {
        /// The study directory.
        study: PathBuf,
        /// The run's name (manifest.json).
        name: String,
    },
    /// Gather the finished runs into one report: STUDY/report/ (report.md, results.csv,
    /// collected.json, learning curves as seed bands), naming unfinished and failed runs.
    Collect {
        /// The study directory.
        study: PathBuf,
        /// Report directory [default: STUDY/report].
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
    },
}

/// Runs a `study` subcommand.
pub fn run(cmd: &StudyCommand) -> anyhow::Result<ExitStatus> {
    match cmd {
        StudyCommand::Plan { spec, out } => plan(spec, out),
        StudyCommand::Run(args) => super::study_run::run(args),
        StudyCommand::Exec { study, name } => exec(study, name),
        StudyCommand::Collect { study, out } => collect_cmd(study, out.as_deref()),
    }
}

/// The files a plan writes, in the order they are moved into place (the manifest last).
const PLAN_FILES: [&str; 5] = [
    "study.toml",
    "commands.txt",
    "slurm.sbatch",
    "ray_driver.py",
    "manifest.json",
];

fn plan(spec_path: &Path, out: &Path) -> anyhow::Result<ExitStatus> {
    let text = read_regular_to_string(spec_path)
        .with_context(|| format!("reading {}", spec_path.display()))?;
    let spec = StudySpec::parse(&text, spec_path)?;
    if out.exists() && !out.is_dir() {
        anyhow::bail!("--out {}: not a directory", out.display());
    }
    let existing = out.join("manifest.json").exists();
    // Every file is written into a hidden directory of --out and moved into place only when
    // all are: a failed plan leaves the study as it was (and no --out it created).
    let staged =
        groundscope::files::StagedDir::new(out).map_err(|e| anyhow::anyhow!("--out {e}"))?;
    plan_into(&spec, &text, spec_path, out, existing, staged)
}

fn plan_into(
    spec: &StudySpec,
    text: &str,
    spec_path: &Path,
    out: &Path,
    existing: bool,
    staged: groundscope::files::StagedDir,
) -> anyhow::Result<ExitStatus> {
    let study = std::fs::canonicalize(out).with_context(|| format!("{}", out.display()))?;
    // Both paths go into every file of the plan: one that a file cannot carry (a newline, a
    // path Slurm misreads) is refused before anything is written.
    groundscope::study::study_path(&study)?;
    let name = study
        .file_name()
        .map_or_else(|| "study".to_owned(), |n| n.to_string_lossy().into_owned());
    let exe = std::env::current_exe()
        .and_then(std::fs::canonicalize)
        .context("finding this binary's path")?;
    let binary = groundscope::study::carried(&exe, "this binary's path")?.to_owned();
    let manifest = spec.plan(&name, &binary);
    check_steps(spec_path, &manifest)?;
    if existing {
        let old = Manifest::read(&study)?;
        check_replan(&old, &manifest)?;
    }
    // Each file lands where a regular file (or nothing) is: a directory in the way is refused
    // before any file moves.
    for file in PLAN_FILES {
        let path = study.join(file);
        if path.is_dir() {
            anyhow::bail!("{}: is a directory", path.display());
        }
    }
    let logs = study.join(SLURM_LOGS);
    if logs.exists() && !logs.is_dir() {
        anyhow::bail!(
            "{}: not a directory (slurm.sbatch writes its logs there)",
            logs.display()
        );
    }
    let json = serde_json::to_string_pretty(&manifest)? + "\n";
    for (file, bytes) in [
        ("study.toml", text.to_owned()),
        ("commands.txt", manifest.commands(&study)),
        ("slurm.sbatch", manifest.sbatch(&study)),
        ("ray_driver.py", Manifest::ray_driver(&study)),
        ("manifest.json", json),
    ] {
        staged.write(file, bytes.as_bytes())?;
    }
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    // Every file is complete: each is renamed into place, the manifest last.
    for file in PLAN_FILES {
        let dest = study.join(file);
        std::fs::rename(staged.path(file), &dest).with_context(|| format!("{}", dest.display()))?;
    }
    // Nothing is left to move: this flushes the directory and removes the staging one.
    staged.commit()?;
    let recipes = spec.recipes.len();
    let levels = spec.levels.len();
    println!(
        "planned {} runs ({recipes} recipes × {levels} level sets × {} seeds) in {}",
        manifest.runs.len(),
        spec.seeds.len(),
        study.display()
    );
    println!(
        "run here: groundscope study run {0}\non Slurm: sbatch {0}/slurm.sbatch\non Ray:   python {0}/ray_driver.py --address auto\nthen:     groundscope study collect {0}",
        study.display()
    );
    Ok(ExitStatus::Success)
}

/// Every step of every run parses as the command it names, and passes the checks that command
/// makes of its flags before it runs ([`super::train::validate`], [`super::eval::validate`],
/// [`super::faithfulness::validate`]): a typo in a recipe, an unknown level id or a value
/// every run refuses (`--epochs 0`, `--alpha 1.5`, `--jobs 0`) is refused at plan time,
/// naming the recipe, the level set and the flag, not hours later on a cluster.
fn check_steps(spec: &Path, m: &Manifest) -> anyhow::Result<()> {
    for run in &m.runs {
        for (cmd, args) in run.steps() {
            let argv = std::iter::once("groundscope")
                .chain(std::iter::once(cmd))
                .chain(args.iter().map(String::as_str));
            let refused = match super::Cli::try_parse_from(argv) {
                // clap's message quotes the flag or value as the spec gave it: escaped and cut.
                Err(e) => Some(
                    e.to_string()
                        .lines()
                        .next()
                        .unwrap_or_default()
                        .trim_start_matches("error: ")
                        .to_owned(),
                ),
                Ok(cli) => checked(cli.command.as_ref())
                    .err()
                    .map(|e| format!("{e:#}")),
            };
            if let Some(why) = refused {
                anyhow::bail!(
                    "{}: recipe {}, level set {}: {cmd}: {}",
                    spec.display(),
                    run.recipe,
                    run.levels,
                    one_line(&why)
                );
            }
        }
    }
    Ok(())
}

/// A parsed step checked as its command checks its flags before it runs (reading no file).
fn checked(command: Option<&super::Command>) -> anyhow::Result<()> {
    match command {
        Some(super::Command::Train(a)) => super::train::validate(a),
        Some(super::Command::Eval(a)) => super::eval::validate(a),
        Some(super::Command::Faithfulness(a)) => super::faithfulness::validate(a),
        _ => Ok(()),
    }
}

/// A run's lock, held: `runs/NAME/.study-lock`, locked with the system's `flock`, which
/// belongs to the open file and is released only when every descriptor of it is closed.
///
/// An exec holds it from before its first step until after its last, and hands it on to every
/// step it starts: each step's standard input is a duplicate of the locked descriptor (the
/// steps read nothing from it). So the run stays locked for as long as any process of the
/// exec runs — an exec killed with SIGKILL during its evaluation leaves that evaluation
/// running, orphaned, and holding the lock — and a second exec of the run meanwhile finds it
/// held and leaves the run alone, instead of starting a second evaluation beside the first
/// (or a training beside a training). This keeps `train`, `eval` and `faithfulness` ordinary
/// child processes (their output goes to `study.log`, a stop is passed on as to any process);
/// `train`'s own lock (`.train-lock`) still guards its run directory against a `train`
/// started by hand. The file says who holds the lock: `exec PID`, and `, STEP PID` while a
/// step runs.
struct RunLock(std::fs::File);

impl RunLock {
    /// Locks `dir`'s run for this process; `None` when another process holds it.
    fn take(dir: &Path) -> anyhow::Result<Option<Self>> {
        let path = dir.join(LOCK_FILE);
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .read(true)
            .write(true)
            .open(&path)
            .with_context(|| format!("opening {}", path.display()))?;
        match file.try_lock() {
            Ok(()) => {
                let lock = Self(file);
                lock.note(None);
                Ok(Some(lock))
            }
            Err(std::fs::TryLockError::WouldBlock) => Ok(None),
            Err(std::fs::TryLockError::Error(e)) => {
                Err(e).with_context(|| format!("locking {}", path.display()))
            }
        }
    }

    /// Who holds `dir`'s run lock, as its file says (`exec PID, STEP PID`), for a message.
    fn holder(dir: &Path) -> String {
        let text = std::fs::read_to_string(dir.join(LOCK_FILE)).unwrap_or_default();
        let text = one_line(text.trim());
        if text.is_empty() {
            "another process".to_owned()
        } else {
            text
        }
    }

    /// Writes who holds the lock into its file: this exec, and `step` (its command and pid)
    /// while one runs. Only a message reads it: a write that fails is left unsaid.
    fn note(&self, step: Option<(&str, u32)>) {
        use std::io::{Seek as _, Write as _};
        let me = std::process::id();
        let text = match step {
            Some((cmd, pid)) => format!("exec {me}, {cmd} {pid}"),
            None => format!("exec {me}"),
        };
        let mut file = &self.0;
        if file.set_len(0).is_ok() && file.seek(std::io::SeekFrom::Start(0)).is_ok() {
            let _ = file.write_all(text.as_bytes());
        }
    }

    /// The standard input of a step: the locked file itself (a duplicate of its descriptor),
    /// so that the step holds the lock for as long as it runs, even past this process.
    fn for_step(&self) -> anyhow::Result<std::process::Stdio> {
        let file = self.0.try_clone().context("duplicating the run's lock")?;
        Ok(std::process::Stdio::from(file))
    }
}

fn exec(study: &Path, name: &str) -> anyhow::Result<ExitStatus> {
    let manifest = Manifest::read(study)?;
    let run = manifest.run(name)?;
    // A hand-edited run is refused before anything of it runs: a name that is not a plain
    // name would put its directory outside runs/, edited steps would run unchecked.
    run.check(&study.join("manifest.json"))?;
    let dir = run.dir(study);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let Some(lock) = RunLock::take(&dir)? else {
        println!(
            "{name}: running elsewhere (its lock is held by {}); left alone",
            RunLock::holder(&dir)
        );
        return Ok(ExitStatus::Success);
    };
    if dir.join(DONE_FILE).is_file() {
        println!("{name}: done");
        return Ok(ExitStatus::Success);
    }
    if let Some(pid) = training_elsewhere(&dir) {
        // A training started by hand (`train --out runs/NAME`) holds the run directory.
        println!("{name}: its training (pid {pid}) is still running; left alone");
        return Ok(ExitStatus::Success);
    }
    let _ = std::fs::remove_file(dir.join(FAILED_FILE));
    let stop = Stop::install();
    let start = std::time::Instant::now();
    for (cmd, args) in run.steps() {
        let args = step_args(study, run, cmd, args);
        let status = run_step(study, &dir, cmd, &args, &stop, &lock)?;
        if let Some(end) = step_ended(name, &dir, cmd, status, &stop)? {
            return Ok(end);
        }
    }
    let done = serde_json::json!({"seconds": start.elapsed().as_secs_f64()});
    write_output(&dir.join(DONE_FILE), done.to_string().as_bytes())?;
    println!("{name}: done in {:.0} s", start.elapsed().as_secs_f64());
    Ok(ExitStatus::Success)
}

/// What the end of step `cmd` of run `name` (in `dir`) means: `None`, go on to the next step;
/// else how the exec ends. A stop asked of the exec, or a step that ended with 130 — stopped
/// by a signal sent to it alone: a training saved before its `--frames`, an evaluation that
/// wrote nothing — is a stopped run: neither done nor failed, it resumes on the next attempt
/// (exit 130, and no evaluation of a part-trained model). Any other failure is a failed run
/// (`study-failed.json`, exit 1).
fn step_ended(
    name: &str,
    dir: &Path,
    cmd: &str,
    status: std::process::ExitStatus,
    stop: &Stop,
) -> anyhow::Result<Option<ExitStatus>> {
    if stop.requested() {
        eprintln!("{name}: interrupted during {cmd}; run the line again to resume it");
        return Ok(Some(ExitStatus::Interrupted));
    }
    if status.code() == Some(130) {
        eprintln!(
            "{name}: {cmd} was stopped by a signal before it ended (exit 130): the run is not done; run the line again to resume it"
        );
        return Ok(Some(ExitStatus::Interrupted));
    }
    if status.success() {
        return Ok(None);
    }
    let code = status
        .code()
        .map_or_else(|| "a signal".to_owned(), |c| c.to_string());
    let failed = serde_json::json!({"step": cmd, "exit": code});
    write_output(&dir.join(FAILED_FILE), failed.to_string().as_bytes())?;
    eprintln!(
        "{name}: {cmd} failed (exit {code}); its output: {}",
        dir.join(LOG_FILE).display()
    );
    Ok(Some(ExitStatus::CheckFailed))
}

/// The pid of a training that holds the run directory's lock, if one does.
fn training_elsewhere(dir: &Path) -> Option<String> {
    let path = dir.join(groundscope::run::RUN_LOCK);
    let file = std::fs::OpenOptions::new().read(true).open(&path).ok()?;
    match file.try_lock() {
        Ok(()) => None,
        Err(_) => Some(
            std::fs::read_to_string(&path)
                .unwrap_or_default()
                .trim()
                .to_owned(),
        ),
    }
}

/// A step's arguments for this attempt: a training that has a checkpoint resumes (without
/// `--init`, which a resume refuses: the run's weights are its own by then).
fn step_args(study: &Path, run: &PlannedRun, cmd: &str, args: &[String]) -> Vec<String> {
    let mut args = args.to_vec();
    if cmd == "train" && groundscope::run::holds_run(&run.dir(study)) {
        if let Some(i) = args.iter().position(|a| a == "--init") {
            args.drain(i..(i + 2).min(args.len()));
        }
        args.push("--resume".into());
    }
    args
}

/// Runs `groundscope CMD ARGS` in the study directory, its output appended to the
/// run's log and the run's lock handed on to it ([`RunLock::for_step`]). A stop asked of this
/// process (SIGINT, SIGTERM, SIGHUP: a runner's or an engine's) is passed on to the step, so
/// that a training saves at its next update and ends.
fn run_step(
    study: &Path,
    dir: &Path,
    cmd: &str,
    args: &[String],
    stop: &Stop,
    lock: &RunLock,
) -> anyhow::Result<std::process::ExitStatus> {
    use std::io::Write as _;
    let log_path = dir.join(LOG_FILE);
    let mut log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .with_context(|| format!("opening {}", log_path.display()))?;
    writeln!(log, "== groundscope {cmd} {}", args.join(" "))?;
    let exe = std::env::current_exe().context("finding this binary")?;
    let mut child = Command::new(exe)
        .arg(cmd)
        .args(args)
        .current_dir(study)
        .stdin(lock.for_step()?)
        .stdout(log.try_clone()?)
        .stderr(log.try_clone()?)
        .spawn()
        .with_context(|| format!("starting groundscope {cmd}"))?;
    lock.note(Some((cmd, child.id())));
    let mut passed_on = false;
    let status = loop {
        if let Some(status) = child.try_wait()? {
            break status;
        }
        if stop.requested() && !passed_on {
            let _ = Command::new("kill")
                .args(["-INT", &child.id().to_string()])
                .status();
            passed_on = true;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    lock.note(None);
    Ok(status)
}

fn collect_cmd(study: &Path, out: Option<&Path>) -> anyhow::Result<ExitStatus> {
    let manifest = Manifest::read(study)?;
    // Names that are not plain would read (and draw) files outside runs/.
    let path = study.join("manifest.json");
    if let Some(bad) = manifest
        .runs
        .iter()
        .find(|r| !groundscope::study::is_plain_name(&r.name))
    {
        bad.check(&path)?;
    }
    let collected = collect(study, &manifest)?;
    let out = out.map_or_else(|| study.join("report"), Path::to_path_buf);
    let staged = groundscope::files::StagedDir::new(&out)
        .with_context(|| format!("creating {}", out.display()))?;
    // Learning curves: one figure per level set, a band per recipe over its finished seeds.
    let mut figures = Vec::new();
    let mut sets: Vec<&str> = manifest.runs.iter().map(|r| r.levels.as_str()).collect();
    sets.dedup();
    sets.sort_unstable();
    sets.dedup();
    for set in sets {
        let logs: Vec<PathBuf> = manifest
            .runs
            .iter()
            .filter(|r| r.levels == set && RunState::of(study, r) == RunState::Done)
            .map(|r| r.dir(study).join("log.csv"))
            .filter(|p| p.is_file())
            .collect();
        if logs.is_empty() {
            continue;
        }
        let file = format!("curves_{set}.png");
        let grounding = super::curve::draw(
            &logs,
            &staged.path(&file),
            super::curve::Accuracy::AccNg,
            false,
        )
        .with_context(|| format!("drawing {file}"))?;
        figures.push(file);
        if grounding {
            figures.push(format!("curves_{set}_grounding.png"));
        }
    }
    staged.write("report.md", collected.markdown(&figures).as_bytes())?;
    staged.write("results.csv", collected.csv().as_bytes())?;
    staged.write(
        "collected.json",
        (serde_json::to_string_pretty(&collected)? + "\n").as_bytes(),
    )?;
    staged.commit_owned(|n| {
        ["report.md", "results.csv", "collected.json"].contains(&n)
            || (n.starts_with("curves_") && Path::new(n).extension().is_some_and(|e| e == "png"))
    })?;
    let done = collected.runs_in(RunState::Done).len();
    println!(
        "collected {done} finished runs of {} into {} rows; report in {}",
        collected.runs.len(),
        collected.rows.len(),
        out.display()
    );
    for state in [RunState::Failed, RunState::Partial, RunState::Pending] {
        let names = collected.runs_in(state);
        if !names.is_empty() {
            println!("{} ({}): {}", state.name(), names.len(), names.join(", "));
        }
    }
    Ok(ExitStatus::Success)
}
