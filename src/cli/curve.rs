//! `groundscope curve`: learning curves, seed bands and the grounding-emergence figure.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use groundscope::metrics::bands::{Band, band, band_panels, read_columns, recipe_of, run_files};
use groundscope::metrics::figures::{Curve, learning_curve, read_training_log};

use super::check_extension;
use crate::ExitStatus;

/// Which accuracy of the tracked evaluation the grounding figure draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Accuracy {
    /// `acc_ng`: the map passes τ somewhere in the object's 3×3 neighbourhood.
    AccNg,
    /// `acc`: the map passes τ on the object's own cell.
    Acc,
}

impl Accuracy {
    /// The tracked evaluation's columns drawn in the grounding figure, with their panel titles.
    fn metrics(self) -> [(&'static str, &'static str); 4] {
        let success = ("greedy_success", "greedy success (held-out)");
        match self {
            Self::AccNg => [
                success,
                ("object_acc_ng", "object-word acc_ng"),
                ("color_acc_ng", "colour-word acc_ng"),
                ("combined_acc_ng", "M on targets, acc_ng"),
            ],
            Self::Acc => [
                success,
                ("object_acc", "object-word acc"),
                ("color_acc", "colour-word acc"),
                ("combined_acc", "M on targets, acc"),
            ],
        }
    }
}

/// Figure panels: a title and the bands drawn in it.
type Panels = Vec<(String, Vec<Band>)>;

/// Draws `out` (mean reward: one line per run, or a band per recipe of several seeds) and,
/// where tracked evaluations sit beside the logs, `out`'s `_grounding.png`. Every file is
/// read before anything is drawn, so a bad one leaves no figure behind.
pub(super) fn curve(
    logs: &[PathBuf],
    out: &Path,
    accuracy: Accuracy,
) -> anyhow::Result<ExitStatus> {
    draw(logs, out, accuracy, true)?;
    Ok(ExitStatus::Success)
}

/// [`curve`]'s figures, saying what it wrote where `say`; returns whether the grounding figure
/// was drawn (`study collect` draws into a staging directory and names the figures itself).
pub(super) fn draw(
    logs: &[PathBuf],
    out: &Path,
    accuracy: Accuracy,
    say: bool,
) -> anyhow::Result<bool> {
    check_extension(out, "png", "--out")?;
    // A glob such as `experiments/runs/*_log.csv` also matches the tracked evaluations; those are
    // read beside their logs, not drawn as logs.
    let logs: Vec<&PathBuf> = logs
        .iter()
        .filter(|p| !p.to_string_lossy().ends_with("eval_log.csv"))
        .collect();
    if logs.is_empty() {
        anyhow::bail!("no training log among the files (only eval_log.csv files were given)");
    }
    // Runs of one recipe (names differing only in a seed suffix) become one band.
    let mut groups: Vec<(String, Vec<&PathBuf>)> = Vec::new();
    for log in logs {
        let recipe = recipe_of(&run_files(log).0);
        match groups.iter_mut().find(|g| g.0 == recipe) {
            Some(g) => g.1.push(log),
            None => groups.push((recipe, vec![log])),
        }
    }
    let rewards = groups
        .iter()
        .map(|(_, paths)| paths.iter().map(|p| read_training_log(p)).collect())
        .collect::<Result<Vec<Vec<_>>, _>>()?;
    let panels = grounding_panels(&groups, &accuracy.metrics())?;

    if groups.iter().all(|g| g.1.len() == 1) {
        let curves: Vec<Curve> = groups
            .iter()
            .zip(rewards)
            .map(|((label, _), mut runs)| Curve {
                label: label.clone(),
                points: runs.swap_remove(0),
            })
            .collect();
        learning_curve(&curves, "Mean reward during training", out)?;
    } else {
        let bands: Vec<Band> = groups
            .iter()
            .zip(&rewards)
            .map(|((label, paths), runs)| band(&format!("{label} (n={})", paths.len()), runs, 100))
            .collect();
        band_panels(
            &[("mean training reward".into(), bands)],
            "Mean reward during training (mean ± std over seeds)",
            out,
        )?;
    }
    if say {
        println!("wrote {}", out.display());
    }
    let stem = out.with_extension("");
    let g = PathBuf::from(format!("{}_grounding.png", stem.display()));
    if let Some(panels) = panels {
        band_panels(
            &panels,
            "Grounding emergence (tracked held-out evaluation)",
            &g,
        )?;
        if say {
            println!("wrote {}", g.display());
        }
        return Ok(true);
    }
    if g.is_file() {
        // An earlier run's grounding figure would pass for this one's.
        std::fs::remove_file(&g).with_context(|| format!("removing {}", g.display()))?;
        if say {
            println!(
                "removed {} (these logs have no tracked evaluation)",
                g.display()
            );
        }
    }
    Ok(false)
}

/// One panel per tracked metric (column, title) with a band per recipe, from the
/// `eval_log.csv` files beside the logs; `None` where no log has one.
fn grounding_panels(
    groups: &[(String, Vec<&PathBuf>)],
    metrics: &[(&str, &str)],
) -> anyhow::Result<Option<Panels>> {
    let mut panels: Panels = metrics
        .iter()
        .map(|m| (m.1.to_owned(), Vec::new()))
        .collect();
    let mut any = false;
    let mut names = vec!["frames"];
    names.extend(metrics.iter().map(|m| m.0));
    for (label, paths) in groups {
        let evals: Vec<PathBuf> = paths
            .iter()
            .map(|p| run_files(p).1)
            .filter(|p| p.exists())
            .collect();
        if evals.is_empty() {
            continue;
        }
        any = true;
        let tables = evals
            .iter()
            .map(|p| read_columns(p, &names))
            .collect::<Result<Vec<_>, _>>()?;
        for (k, panel) in panels.iter_mut().enumerate() {
            let runs: Vec<Vec<(f64, f64)>> = tables
                .iter()
                .map(|rows| rows.iter().map(|r| (r[0], r[k + 1])).collect())
                .collect();
            panel
                .1
                .push(band(&format!("{label} (n={})", evals.len()), &runs, 50));
        }
    }
    Ok(any.then_some(panels))
}
