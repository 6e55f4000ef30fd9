//! What can go wrong with a study's files: each error names the file and the field (or the
//! run), in one line.

use std::path::PathBuf;

/// An error in a study's spec, manifest or runs' files.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// `study.toml` refused: what is wrong names the field.
    #[error("{}: {what}", file.display())]
    Spec {
        /// The spec.
        file: PathBuf,
        /// What is wrong with it.
        what: String,
    },
    /// `manifest.json` cannot be read: the study was not planned (or not there).
    #[error(
        "{}: {error} (plan the study first: groundscope study plan SPEC --out {})",
        path.display(),
        study.display()
    )]
    NoManifest {
        /// The manifest.
        path: PathBuf,
        /// The study directory.
        study: PathBuf,
        /// The system's error.
        error: std::io::Error,
    },
    /// `manifest.json` is not a manifest this groundscope reads.
    #[error("{}: {what}", path.display())]
    BadManifest {
        /// The manifest.
        path: PathBuf,
        /// What is wrong with it.
        what: String,
    },
    /// `manifest.json` was planned by an earlier groundscope, whose runs' steps were command
    /// lines: the command line's own parser turns them into typed steps ([`super::Stored`]).
    #[error(
        "{}: planned by an earlier groundscope (its runs' steps are command lines); plan the study again: groundscope study plan STUDY/study.toml --out STUDY",
        path.display()
    )]
    CommandLines {
        /// The manifest.
        path: PathBuf,
    },
    /// A run of the manifest that was edited by hand: refused before anything of it runs.
    #[error(
        "{}: {what}: the manifest was edited; plan the study again (groundscope study plan SPEC --out STUDY)",
        path.display()
    )]
    Edited {
        /// The manifest.
        path: PathBuf,
        /// What was edited, the run named.
        what: String,
    },
    /// No run of that name in the study.
    #[error("the study {study} has no run {name} (its runs: {runs})")]
    NoRun {
        /// The study's name, quoted.
        study: String,
        /// The name asked for, quoted.
        name: String,
        /// The first of its runs' names.
        runs: String,
    },
    /// A new plan that drops a planned run: its directory holds results of the old steps.
    #[error(
        "the new spec drops run {0} of the planned study; a study's runs may only be added (plan into a new --out)"
    )]
    Dropped(String),
    /// A new plan that changes a planned run's steps.
    #[error(
        "the new spec changes run {run} (its {step} step differs from the planned one); a study's runs may only be added (plan into a new --out)"
    )]
    Changed {
        /// The run.
        run: String,
        /// The first step that differs.
        step: super::Step,
    },
    /// A path that the plan's files cannot carry: `what` names it (`--out`, this binary's
    /// path), `path` is quoted.
    #[error("{what} {path}: {why}")]
    Path {
        /// Which path.
        what: String,
        /// The path, quoted.
        path: String,
        /// Why no file of the plan can carry it, and what to do.
        why: String,
    },
    /// A finished run's file (its evaluation or faithfulness report) that cannot be read.
    #[error("{}: {what}", path.display())]
    RunFile {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        what: String,
    },
    /// A run's steps that do not write as JSON (never for the steps a plan makes).
    #[error("run {run}: its steps as JSON: {error}")]
    Json {
        /// The run.
        run: String,
        /// serde's message.
        error: String,
    },
}
