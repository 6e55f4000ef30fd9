//! The files an engine runs a study from, one `study exec STUDY NAME` line per run:
//! `commands.txt`, the Slurm array `slurm.sbatch` and the Ray driver `ray_driver.py`, each path
//! written as that file's reader parses it, and the paths no file can carry refused.

use std::fmt::Write as _;
use std::path::Path;

use super::{Manifest, SLURM_LOGS, StudyError, shown};

impl Manifest {
    /// `commands.txt`: one line per run, each word quoted as sh reads it (`sh_word`), so
    /// that a binary or a study whose path holds a space or a quote runs as planned.
    pub fn commands(&self, study: &Path) -> String {
        let binary = sh_word(&self.binary);
        let dir = shell(study);
        let mut out = String::new();
        for r in &self.runs {
            let _ = writeln!(out, "{binary} study exec {dir} {}", sh_word(&r.name));
        }
        out
    }

    /// `slurm.sbatch`: an array of one task per line of `commands.txt`, each with the CPUs its
    /// training uses; logs in `slurm-logs/`. Paths in the script's body are quoted as sh reads
    /// them; those of the `#SBATCH` lines, which sbatch reads itself, as sbatch does
    /// (`sbatch_value`).
    pub fn sbatch(&self, study: &Path) -> String {
        let cpus = self.runs.iter().map(|r| r.threads).max().unwrap_or(1);
        let last = self.runs.len().saturating_sub(1);
        let name = &self.name;
        // A job's name is only shown: letters, digits and `_.-` of the study's, the rest `_`.
        let job: String = name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "_.-".contains(c) {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        // `%` starts one of Slurm's file name patterns (`%A`, `%a`): a literal one is `%%`.
        let logs = format!(
            "{}/{SLURM_LOGS}/%A_%a.txt",
            study.display().to_string().replace('%', "%%")
        );
        let output = sbatch_value(&logs);
        let script = shell(&study.join("slurm.sbatch"));
        let commands = shell(&study.join("commands.txt"));
        let dir = shell(study);
        format!(
            "#!/bin/bash\n\
             # groundscope study {name}: one array task per line of commands.txt.\n\
             # Submit: sbatch {script}   (then: groundscope study collect {dir})\n\
             #SBATCH --job-name=gs-{job}\n\
             #SBATCH --array=0-{last}\n\
             #SBATCH --cpus-per-task={cpus}\n\
             #SBATCH --output={output}\n\
             set -euo pipefail\n\
             line=$(sed -n \"$((SLURM_ARRAY_TASK_ID + 1))p\" {commands})\n\
             exec bash -c \"$line\"\n"
        )
    }

    /// `ray_driver.py`: every run as a Ray task with `num_cpus` = its threads, on the cluster
    /// at `--address` (default: a local one); waits for all and names the ones that failed.
    pub fn ray_driver(study: &Path) -> String {
        // A JSON string is a Python string literal, whatever the path holds.
        let literal = serde_json::to_string(&study.display().to_string()).unwrap_or_default();
        include_str!("ray_driver.py").replace("\"@STUDY@\"", &literal)
    }
}

/// A path that the plan writes into its files (`commands.txt`, `slurm.sbatch`,
/// `ray_driver.py`, `manifest.json`), as text; `what` names it in the error. Refused where
/// those files cannot carry it: a path that is not UTF-8 (the manifest is JSON text), or that
/// holds a control character — a newline would end a line of `commands.txt` (a task would run
/// half a path) and, in `slurm.sbatch`, run the rest of the path as a command.
pub fn carried<'a>(path: &'a Path, what: &str) -> Result<&'a str, StudyError> {
    let Some(text) = path.to_str() else {
        return Err(StudyError::Path {
            what: what.to_owned(),
            path: shown(&path.to_string_lossy()),
            why: "not valid UTF-8, which manifest.json and the study's scripts cannot carry; choose another path".to_owned(),
        });
    };
    if let Some(c) = text.chars().find(|&c| c.is_control()) {
        return Err(StudyError::Path {
            what: what.to_owned(),
            path: shown(text),
            why: format!(
                "holds a control character ('{}'), which commands.txt and slurm.sbatch cannot carry (a newline would end a command line, or run the rest of the path as a command); choose a path without one",
                c.escape_debug()
            ),
        });
    }
    Ok(text)
}

/// The study directory's path as the plan writes it ([`carried`]), also refused where it
/// holds a backslash: Slurm reads a `\` in `--output` as "no file name patterns", so every
/// task of `slurm.sbatch` would log into one file named `%A_%a.txt`. `what` names the path in
/// the error (the option that gave it).
pub fn study_path<'a>(study: &'a Path, what: &str) -> Result<&'a str, StudyError> {
    let text = carried(study, what)?;
    if text.contains('\\') {
        return Err(StudyError::Path {
            what: what.to_owned(),
            path: shown(text),
            why: "holds a backslash, which slurm.sbatch cannot carry (Slurm reads one in --output as \"no file name patterns\": every task would log into one file); choose a path without one".to_owned(),
        });
    }
    Ok(text)
}

/// Whether `s` needs no quoting: letters, digits and `/._-+,=:` (`%` too for sbatch).
fn plain_word(s: &str, extra: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+,=:".contains(c) || extra.contains(c))
}

/// `s` as one sh word: as it is where it holds only safe characters, else in single quotes,
/// each `'` written `'\''` (sh takes everything between single quotes literally).
fn sh_word(s: &str) -> String {
    if plain_word(s, "") {
        s.to_owned()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// A path as one sh word ([`sh_word`]).
fn shell(p: &Path) -> String {
    sh_word(&p.display().to_string())
}

/// A value of a `#SBATCH` option as sbatch's own parser of those lines reads it back: as it
/// is where it holds only safe characters, else in double quotes (sbatch ends a value at a
/// space outside quotes) with `\`, `"`, `'` and `#` escaped by a backslash (sbatch undoes a
/// backslash before any character, ends a quote at its own quote character, and takes a `#`
/// as the start of a comment — outside quotes, and in older versions inside them too).
fn sbatch_value(s: &str) -> String {
    if plain_word(s, "%") {
        return s.to_owned();
    }
    let mut out = String::from("\"");
    for c in s.chars() {
        if matches!(c, '\\' | '"' | '\'' | '#') {
            out.push('\\');
        }
        out.push(c);
    }
    out.push('"');
    out
}
