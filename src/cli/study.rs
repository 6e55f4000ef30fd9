//! `groundscope study plan | run | exec | collect`: a seeds × recipes × levels grid planned
//! into typed runs (`study_plan.rs`, `groundscope::study`), run here N at a time
//! (`study_run.rs`), on Slurm or on Ray, one `study exec` line per run (`study_exec.rs`), and
//! collected from the runs' own reports.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::Subcommand;
use groundscope::study::RunState;
use groundscope::study::collect::collect;

use crate::ExitStatus;

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
    /// Run one run's steps in this process — train (resumed where it was killed), eval,
    /// faithfulness — into STUDY/runs/NAME: what each line of commands.txt does. A run that is
    /// running elsewhere (its directory's lock held) or finished is left alone.
    Exec {
        /// The study directory.
        study: PathBuf,
        /// The run's name (manifest.json).
        name: String,
        /// Write how the attempt ended into FILE (JSON: done, elsewhere, stopped or failed),
        /// for the runner that started it.
        #[arg(long, value_name = "FILE", hide = true)]
        outcome: Option<PathBuf>,
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
        StudyCommand::Plan { spec, out } => super::study_plan::plan(spec, out),
        StudyCommand::Run(args) => super::study_run::run(args),
        StudyCommand::Exec {
            study,
            name,
            outcome,
        } => super::study_exec::exec(study, name, outcome.as_deref()),
        StudyCommand::Collect { study, out } => collect_cmd(study, out.as_deref()),
    }
}

fn collect_cmd(study: &Path, out: Option<&Path>) -> anyhow::Result<ExitStatus> {
    let manifest = super::study_legacy::read_manifest(study, true)?;
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
