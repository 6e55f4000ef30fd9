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
    let name = study
        .file_name()
        .map_or_else(|| "study".to_owned(), |n| n.to_string_lossy().into_owned());
    let binary = std::env::current_exe()
        .and_then(std::fs::canonicalize)
        .context("finding this binary's path")?
        .display()
        .to_string();
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

/// Every step of every run parses as the command it names: a typo in a recipe is refused at
/// plan time, naming the recipe, not hours later on a cluster.
fn check_steps(spec: &Path, m: &Manifest) -> anyhow::Result<()> {
    for run in &m.runs {
        for (cmd, args) in run.steps() {
            let argv = std::iter::once("groundscope")
                .chain(std::iter::once(cmd))
                .chain(args.iter().map(String::as_str));
            if let Err(e) = super::Cli::try_parse_from(argv) {
                // clap's message quotes the flag or value as the spec gave it: escaped and cut.
                let first = e.to_string();
                let first = first
                    .lines()
                    .next()
                    .unwrap_or_default()
                    .trim_start_matches("error: ");
                anyhow::bail!(
                    "{}: recipe {}, level set {}: {cmd}: {}",
                    spec.display(),
                    run.recipe,
                    run.levels,
                    one_line(first)
                );
            }
        }
    }
    Ok(())
}

/// A held run lock (released when dropped or when the process dies).
struct RunLock(#[expect(dead_code, reason = "held for its lock")] std::fs::File);

/// Locks `dir`'s run for this process; `None` when another process holds it.
fn lock_run(dir: &Path) -> anyhow::Result<Option<RunLock>> {
    let path = dir.join(LOCK_FILE);
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .with_context(|| format!("opening {}", path.display()))?;
    match file.try_lock() {
        Ok(()) => Ok(Some(RunLock(file))),
        Err(std::fs::TryLockError::WouldBlock) => Ok(None),
        Err(std::fs::TryLockError::Error(e)) => {
            Err(e).with_context(|| format!("locking {}", path.display()))
        }
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
    let Some(_lock) = lock_run(&dir)? else {
        println!("{name}: running elsewhere (its lock is held); left alone");
        return Ok(ExitStatus::Success);
    };
    if dir.join(DONE_FILE).is_file() {
        println!("{name}: done");
        return Ok(ExitStatus::Success);
    }
    if let Some(pid) = training_elsewhere(&dir) {
        // An executor killed alone leaves its training running on: that one goes on.
        println!("{name}: its training (pid {pid}) is still running; left alone");
        return Ok(ExitStatus::Success);
    }
    let _ = std::fs::remove_file(dir.join(FAILED_FILE));
    let stop = Stop::install();
    let start = std::time::Instant::now();
    for (cmd, args) in run.steps() {
        let args = step_args(study, run, cmd, args);
        let status = run_step(study, &dir, cmd, &args, &stop)?;
        if stop.requested() {
            eprintln!("{name}: interrupted during {cmd}; run the line again to resume it");
            return Ok(ExitStatus::Interrupted);
        }
        if !status.success() {
            let code = status
                .code()
                .map_or_else(|| "a signal".to_owned(), |c| c.to_string());
            let failed = serde_json::json!({"step": cmd, "exit": code});
            write_output(&dir.join(FAILED_FILE), failed.to_string().as_bytes())?;
            eprintln!(
                "{name}: {cmd} failed (exit {code}); its output: {}",
                dir.join(LOG_FILE).display()
            );
            return Ok(ExitStatus::CheckFailed);
        }
    }
    let done = serde_json::json!({"seconds": start.elapsed().as_secs_f64()});
    write_output(&dir.join(DONE_FILE), done.to_string().as_bytes())?;
    println!("{name}: done in {:.0} s", start.elapsed().as_secs_f64());
    Ok(ExitStatus::Success)
}

/// The pid of a training that holds the run directory's lock, if one does.
fn training_elsewhere(dir: &Path) -> Option<String> {
    let path = dir.join(groundscope::policy::ppo::run_dir::RUN_LOCK);
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
    if cmd == "train" && groundscope::policy::ppo::run_dir::holds_run(&run.dir(study)) {
        if let Some(i) = args.iter().position(|a| a == "--init") {
            args.drain(i..(i + 2).min(args.len()));
        }
        args.push("--resume".into());
    }
    args
}

/// Runs `groundscope CMD ARGS` in the study directory, its output appended to the run's log.
/// A stop asked of this process (SIGINT, SIGTERM, SIGHUP: a runner's or an engine's) is passed
/// on to the step, so that a training saves at its next update and ends.
fn run_step(
    study: &Path,
    dir: &Path,
    cmd: &str,
    args: &[String],
    stop: &Stop,
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
        .stdin(std::process::Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log.try_clone()?)
        .spawn()
        .with_context(|| format!("starting groundscope {cmd}"))?;
    let mut passed_on = false;
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(status);
        }
        if stop.requested() && !passed_on {
            let _ = Command::new("kill")
                .args(["-INT", &child.id().to_string()])
                .status();
            passed_on = true;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
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
