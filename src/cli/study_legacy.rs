//! Plans written before a study's steps were typed: a `manifest.json` without a `version`,
//! whose runs' steps are the arguments of `train`, `eval` and `faithfulness`. Such a plan still
//! runs: the first command that reads it converts it, through the same parser a plan uses
//! ([`super::study_steps::typed_steps`]), into the typed steps a plan of its spec writes now,
//! and writes it back so, once.

use std::path::Path;

use groundscope::files::write_output;
use groundscope::study::{
    Manifest, PlannedRun, Stored, StudyError, is_plain_name, one_line, shown,
};
use serde::Deserialize;
use sha2::{Digest as _, Sha256};

/// What an earlier version's manifest says of the study (its `format` is checked when it is
/// read; its runs' `threads` follow from their training again).
#[derive(Deserialize)]
struct OldManifest {
    name: String,
    binary: String,
    runs: Vec<OldRun>,
}

/// One run of an earlier version's manifest.
#[derive(Deserialize)]
struct OldRun {
    name: String,
    recipe: String,
    levels: String,
    seed: u64,
    train: Vec<String>,
    eval: Vec<String>,
    #[serde(default)]
    faithfulness: Option<Vec<String>>,
    hash: String,
}

impl OldRun {
    /// The hash that version gave a run: SHA-256 of its name, then each step's command and
    /// arguments, each behind a separator byte.
    fn hash_of_steps(&self) -> String {
        let mut steps = vec![("train", &self.train), ("eval", &self.eval)];
        if let Some(f) = &self.faithfulness {
            steps.push(("faithfulness", f));
        }
        let mut h = Sha256::new();
        h.update(self.name.as_bytes());
        for (cmd, args) in steps {
            h.update([0]);
            h.update(cmd.as_bytes());
            for a in args {
                h.update([1]);
                h.update(a.as_bytes());
            }
        }
        format!("{:x}", h.finalize())
    }
}

/// `STUDY/manifest.json`, typed. One planned by an earlier version is converted ([`convert`])
/// and, with `rewrite`, written back in this version's form, so that later readers read it as
/// a plan writes it now; a note on stderr says so (or why it was left as it was).
pub(super) fn read_manifest(study: &Path, rewrite: bool) -> anyhow::Result<Manifest> {
    let (path, text) = match Manifest::read_stored(study)? {
        Stored::Typed(m) => return Ok(m),
        Stored::CommandLines { path, text } => (path, text),
    };
    let manifest = convert(&path, &text)?;
    if rewrite {
        let written = manifest
            .to_json()
            .map_err(anyhow::Error::from)
            .and_then(|json| write_output(&path, json.as_bytes()).map_err(anyhow::Error::from));
        match written {
            Ok(()) => eprintln!(
                "note: {}: planned by an earlier groundscope, its runs' steps command lines: converted into typed steps, as a plan writes them now",
                path.display()
            ),
            Err(e) => eprintln!(
                "note: {}: planned by an earlier groundscope, its runs' steps command lines: read as typed steps, and left as it was ({e:#})",
                path.display()
            ),
        }
    }
    Ok(manifest)
}

/// An earlier version's manifest (at `path`, its text `text`) as this version's: each run
/// checked as that version checked it (a plain name, its steps hashing to its hash), then its
/// steps parsed as a plan parses them. A run whose steps no longer parse (a flag this version
/// does not have) is refused by name, with the way out: plan the study again.
fn convert(path: &Path, text: &str) -> anyhow::Result<Manifest> {
    let old: OldManifest = serde_json::from_str(text).map_err(|e| StudyError::BadManifest {
        path: path.to_path_buf(),
        what: one_line(&e.to_string()),
    })?;
    let edited = |what: String| StudyError::Edited {
        path: path.to_path_buf(),
        what,
    };
    let mut runs = Vec::new();
    for r in &old.runs {
        if !is_plain_name(&r.name) {
            return Err(edited(format!(
                "run name {} is not a plain name (letters, digits, '_', '.' and '-', as a plan writes them)",
                shown(&r.name)
            ))
            .into());
        }
        if r.hash_of_steps() != r.hash {
            return Err(edited(format!(
                "run {}: its steps do not hash to its recorded hash",
                r.name
            ))
            .into());
        }
        let steps = super::study_steps::typed_steps(&r.train, &r.eval, r.faithfulness.as_deref())
            .map_err(|why| {
                anyhow::anyhow!(
                    "{}: run {}, planned by an earlier groundscope: {why}; plan the study again (groundscope study plan STUDY/study.toml --out STUDY)",
                    path.display(),
                    r.name
                )
            })?;
        runs.push(PlannedRun::new(
            &r.name, &r.recipe, &r.levels, r.seed, steps,
        )?);
    }
    Ok(Manifest::new(&old.name, &old.binary, runs))
}
