//! `eval`'s worst episodes run again (the same level, seed and action mode as in the sweep)
//! for what `--export-failures` and `--html` keep of each: a Rerun recording in
//! `DIR/failures/`, an HTML page in `DIR/episodes/`. Each episode is run once for both.

use std::path::Path;

use anyhow::Context as _;
use groundscope::episode::{ActionMode, EpisodeSpec};
use groundscope::metrics::report::{EpisodePages, Failure};
use groundscope::policy::Agent;
use groundscope::record::{RecordError, RerunTargets, html::episode_page, record_rerun};

use super::stop::Stop;

/// What to make of each listed episode.
pub(super) struct Outputs<'a> {
    /// Record it for Rerun into the first directory (staged), named in errors by the second
    /// (where the recordings are going).
    pub rrd: Option<(&'a Path, &'a Path)>,
    /// Make its HTML page.
    pub html: bool,
}

/// What was made: how many failed episodes and successes were recorded, and the pages.
#[derive(Default)]
pub(super) struct Listed {
    pub failed: usize,
    pub successes: usize,
    pub pages: EpisodePages,
}

/// Replays every listed episode once and makes what `outputs` asks for. An episode listed
/// twice (a long failure with a low acc_cmb too) is run once, under the first kind it is
/// listed for (`failed` comes first): one recording, one page, which both rows link.
pub(super) fn run_listed(
    failures: &[Failure],
    ckpts: &[(String, Agent)],
    outputs: &Outputs<'_>,
    mode: ActionMode,
    alpha: f64,
    stop: &Stop,
) -> anyhow::Result<Listed> {
    let mut out = Listed::default();
    let mut seen = std::collections::HashSet::new();
    for f in failures {
        let Some((name, ckpt)) = ckpts.iter().find(|(n, _)| *n == f.checkpoint) else {
            continue;
        };
        let key = (
            &f.checkpoint,
            &f.level,
            f.size,
            f.objects,
            f.seed,
            f.done_required,
        );
        if !seen.insert(key) {
            continue;
        }
        let spec = EpisodeSpec {
            level: f.level_config(ckpt.level())?,
            seed: f.seed,
            mission: None,
            mode,
        };
        let trace = groundscope::episode::run_from(
            &stop.guard(ckpt.acting()),
            name,
            &spec,
            groundscope::episode::initial_world(&spec)?,
        )?;
        if let Some((dir, shown)) = outputs.rrd {
            let file = format!("{}-{}.rrd", f.kind, f.file_stem());
            let targets = RerunTargets {
                save: Some(dir.join(&file)),
                ..RerunTargets::default()
            };
            record_rerun(std::slice::from_ref(&trace), &targets, alpha, None).map_err(
                |e| match e {
                    RecordError::Io { reason, .. } => {
                        anyhow::anyhow!("cannot write {}: {reason}", shown.join(&file).display())
                    }
                    e => e.into(),
                },
            )?;
            if trace.success() {
                out.successes += 1;
            } else {
                out.failed += 1;
            }
        }
        if outputs.html {
            let page = episode_page(&[&trace], alpha, None)?;
            out.pages.pages.push((f.page_name(), page));
        }
    }
    Ok(out)
}

/// Puts this run's recordings (the directory `staged`) in place of an earlier run's at `dir`:
/// the earlier `*.rrd` removed, then the directory renamed into place, or, where `dir` keeps
/// files of the user's own, each recording moved in beside them.
pub(super) fn put_failures_in_place(staged: &Path, dir: &Path) -> anyhow::Result<()> {
    remove_old_failures(dir)?;
    let moved =
        |e: std::io::Error| anyhow::anyhow!("cannot move recordings to {}: {e}", dir.display());
    if !dir.exists() {
        return std::fs::rename(staged, dir).map_err(moved);
    }
    for entry in std::fs::read_dir(staged).map_err(moved)? {
        let entry = entry.map_err(moved)?;
        std::fs::rename(entry.path(), dir.join(entry.file_name())).map_err(moved)?;
    }
    Ok(())
}

/// Removes an earlier run's `failures/` recordings (`*.rrd`), and the directory when nothing
/// else is in it.
pub(super) fn remove_old_failures(dir: &Path) -> anyhow::Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if entry.file_type().is_ok_and(|t| t.is_file())
            && path.extension().is_some_and(|e| e == "rrd")
        {
            std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
        }
    }
    // Only an empty directory is removed.
    let _ = std::fs::remove_dir(dir);
    Ok(())
}
