//! `study collect`: the runs' own evaluation (and faithfulness) reports gathered into one
//! table per recipe × level set × evaluated level, mean ± std over seeds, with the runs that
//! are not finished named. Reads only finished runs, so it can run while the study runs.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::{DONE_FILE, Manifest, RunState, StudyError, one_line};
use crate::metrics::faithfulness::report::{FaithfulnessFigures, REPORT_FILE};
use crate::metrics::grounding::WordKind;
use crate::metrics::report::Report;
use crate::metrics::sweep::MeanStd;
use crate::table::{Record, Table};

/// One row of the collected report: a recipe on a level set, evaluated on one level.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    /// Recipe.
    pub recipe: String,
    /// Level set.
    pub levels: String,
    /// The evaluated level (a BabyAI id, or `S8N4` for the paper's).
    pub level: String,
    /// The seeds whose runs are finished.
    pub seeds: Vec<u64>,
    /// Every figure by name (`success`, `reward`, `object_acc`, `object_pointing`, …),
    /// mean ± std over the seeds.
    pub figures: BTreeMap<String, MeanStd>,
}

/// The collected study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Collected {
    /// The study's name.
    pub study: String,
    /// Every run and where it stands.
    pub runs: Vec<(String, RunState)>,
    /// One row per recipe × level set × evaluated level.
    pub rows: Vec<Row>,
}

/// A row's key: recipe, level set, evaluated level.
type CellKey = (String, String, String);

/// One seed's figures by name.
type SeedFigures = (u64, BTreeMap<String, f64>);

/// The figures of one finished run's reports, per evaluated level.
type RunFigures = BTreeMap<String, BTreeMap<String, f64>>;

/// Gathers study `dir`'s finished runs.
pub fn collect(study: &Path, manifest: &Manifest) -> Result<Collected, StudyError> {
    let mut runs = Vec::new();
    let mut cells: BTreeMap<CellKey, Vec<SeedFigures>> = BTreeMap::new();
    for run in &manifest.runs {
        let state = RunState::of(study, run);
        runs.push((run.name.clone(), state));
        if state != RunState::Done {
            continue;
        }
        for (level, figures) in run_figures(&run.dir(study))? {
            cells
                .entry((run.recipe.clone(), run.levels.clone(), level))
                .or_default()
                .push((run.seed, figures));
        }
    }
    let rows = cells
        .into_iter()
        .map(|((recipe, levels, level), per_seed)| {
            let names: std::collections::BTreeSet<&String> =
                per_seed.iter().flat_map(|(_, f)| f.keys()).collect();
            let figures = names
                .into_iter()
                .map(|n| {
                    let vals: Vec<f64> = per_seed
                        .iter()
                        .map(|(_, f)| f.get(n).copied().unwrap_or(f64::NAN))
                        .collect();
                    (n.clone(), MeanStd::of(&vals))
                })
                .collect();
            Row {
                recipe,
                levels,
                level,
                seeds: per_seed.iter().map(|(s, _)| *s).collect(),
                figures,
            }
        })
        .collect();
    Ok(Collected {
        study: manifest.name.clone(),
        runs,
        rows,
    })
}

/// The headline figures of one finished run, per evaluated level: task performance, each word
/// class's `acc`, pointing game and mass with their chance, and the faithfulness report's
/// closed-loop success and localisation where it ran.
fn run_figures(run: &Path) -> Result<RunFigures, StudyError> {
    let path = run.join("eval").join("report.json");
    let report: Report = read_json(&path)?;
    let mut out = RunFigures::new();
    for c in &report.cells {
        let level = c
            .level
            .clone()
            .unwrap_or_else(|| format!("S{}N{}", c.size, c.objects));
        let f = out.entry(level).or_default();
        for (name, m) in [
            ("success", &c.success),
            ("reward", &c.reward),
            ("length", &c.length),
        ] {
            if let Some(v) = m.mean {
                f.insert(name.into(), v);
            }
        }
        if let Some(a) = &c.accuracy {
            for (kind, g) in a.by_kind() {
                let k = kind.name();
                for (name, m) in [
                    ("acc", &g.acc),
                    ("pointing", &g.pointing),
                    ("mass", &g.mass),
                ] {
                    if let Some(v) = m.mean {
                        f.insert(format!("{k}_{name}"), v);
                    }
                }
                if let Some(v) = g.chance_mean(4) {
                    f.insert(format!("{k}_chance"), v);
                }
            }
        }
    }
    let faith = run.join("faithfulness").join(REPORT_FILE);
    if faith.is_file() {
        add_faithfulness(&faith, &mut out)?;
    }
    Ok(out)
}

/// A finished run's report at `path`, read through its own types: a renamed field is a compile
/// error or a refused file naming it, never a silent gap.
fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, StudyError> {
    let text = crate::files::read_regular_to_string(path).map_err(|e| StudyError::RunFile {
        path: path.to_path_buf(),
        what: format!("{e} (the run has {DONE_FILE})"),
    })?;
    serde_json::from_str(&text).map_err(|e| StudyError::RunFile {
        path: path.to_path_buf(),
        what: one_line(&e.to_string()),
    })
}

/// The faithfulness report at `faith` (what the run's faithfulness step writes), its
/// closed-loop success per intervention and `M`'s pointing game added to the figures of the
/// level it names.
fn add_faithfulness(faith: &Path, out: &mut RunFigures) -> Result<(), StudyError> {
    let report: FaithfulnessFigures = read_json(faith)?;
    for c in &report.checkpoints {
        // The faithfulness report names a level `S8N4 goto` or `ID (done-action mode)`: its
        // first word is the name the evaluation's rows have.
        let level = c
            .level
            .split_whitespace()
            .next()
            .unwrap_or_default()
            .to_owned();
        let f = out.entry(level).or_default();
        for (name, l) in &c.closed_loop {
            if let Some(x) = l.success.mean {
                f.insert(format!("faith_{name}_success"), x);
            }
        }
        if let Some(x) = c
            .localisation
            .get(&WordKind::Combined)
            .and_then(|l| l.pointing_game.value.mean)
        {
            f.insert("faith_m_pointing".into(), x);
        }
    }
    Ok(())
}

impl Collected {
    /// `results.csv`: one line per row and figure (long format).
    pub fn csv(&self) -> String {
        let mut t = Table::new("recipe,levels,level,seeds,figure,mean,std");
        for r in &self.rows {
            for (name, m) in &r.figures {
                t.push(
                    &Record::new()
                        .field(&r.recipe)
                        .field(&r.levels)
                        .field(&r.level)
                        .field(r.seeds.len())
                        .field(name)
                        .mean_std(m),
                );
            }
        }
        t.finish()
    }

    /// Runs in `state`.
    pub fn runs_in(&self, state: RunState) -> Vec<&str> {
        self.runs
            .iter()
            .filter(|(_, s)| *s == state)
            .map(|(n, _)| n.as_str())
            .collect()
    }

    /// `report.md`.
    pub fn markdown(&self, figures: &[String]) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Study {}\n", self.study);
        let done = self.runs_in(RunState::Done).len();
        let _ = writeln!(
            s,
            "{done} of {} runs finished; every figure is the mean ± std over the finished seeds of each recipe (a seed's figure is its run's own `eval` report).\n",
            self.runs.len()
        );
        for state in [RunState::Failed, RunState::Partial, RunState::Pending] {
            let names = self.runs_in(state);
            if !names.is_empty() {
                let _ = writeln!(
                    s,
                    "- {} ({}): {}",
                    state.name(),
                    names.len(),
                    names.join(", ")
                );
            }
        }
        let names: std::collections::BTreeSet<&String> =
            self.rows.iter().flat_map(|r| r.figures.keys()).collect();
        // Task performance first, then the word classes in report order (each: acc, pointing,
        // mass, chance), then faithfulness.
        let order = |n: &str| -> (usize, usize) {
            if let Some(i) = ["success", "reward", "length"].iter().position(|x| *x == n) {
                return (0, i);
            }
            for (k, kind) in WordKind::ALL.iter().enumerate() {
                if let Some(rest) = n.strip_prefix(&format!("{}_", kind.name())) {
                    let i = ["acc", "pointing", "mass", "chance"]
                        .iter()
                        .position(|x| *x == rest)
                        .unwrap_or(4);
                    return (1 + k, i);
                }
            }
            (9, 0)
        };
        let mut names: Vec<&String> = names.into_iter().collect();
        names.sort_by_key(|n| (order(n), n.as_str().to_owned()));
        let _ = writeln!(s, "\n## Results\n");
        let _ = writeln!(
            s,
            "| recipe | levels | level | seeds | {} |",
            names
                .iter()
                .map(|n| n.as_str())
                .collect::<Vec<_>>()
                .join(" | ")
        );
        let _ = writeln!(s, "|---|---|---|---|{}", "---|".repeat(names.len()));
        for r in &self.rows {
            let cells: Vec<String> = names
                .iter()
                .map(|n| {
                    r.figures
                        .get(*n)
                        .map_or_else(|| "–".into(), |m| m.shown(r.seeds.len() > 1))
                })
                .collect();
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} |",
                r.recipe,
                r.levels,
                r.level,
                r.seeds.len(),
                cells.join(" | ")
            );
        }
        let _ = writeln!(
            s,
            "\n`*_acc`, `*_pointing`, `*_mass`: a word class's `acc`, pointing game and relevance mass (`combined` is `M` on the targets); `*_chance`: a uniform map's pointing game and mass on the same steps (docs/evaluation.md). `faith_*`: the faithfulness report's closed-loop success per intervention and `M`'s pointing game."
        );
        if !figures.is_empty() {
            let _ = writeln!(s, "\n## Learning curves\n");
            for f in figures {
                let _ = writeln!(s, "![{f}]({f})");
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_faithfulness_report_is_read_through_its_types_and_a_renamed_field_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(REPORT_FILE);
        let figure = r#"{"mean": 0.75, "std": null}"#;
        let report = format!(
            r#"{{"schema_version": 1, "checkpoints": [{{"level": "S8N4 goto",
                "closed_loop": {{"none": {{"success": {figure}, "distractor": {figure}, "episodes": 4}}}},
                "localisation": {{}}}}]}}"#
        );
        std::fs::write(&path, &report).unwrap();
        let mut out = RunFigures::new();
        add_faithfulness(&path, &mut out).unwrap();
        assert_eq!(out["S8N4"]["faith_none_success"], 0.75);
        // A field the report no longer has under that name is a refused file, never a gap.
        std::fs::write(&path, report.replace("closed_loop", "closed_loops")).unwrap();
        let e = add_faithfulness(&path, &mut RunFigures::new())
            .unwrap_err()
            .to_string();
        assert!(e.contains(REPORT_FILE) && e.contains("closed_loop"), "{e}");
    }
}
