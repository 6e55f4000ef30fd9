//! The faithfulness report as text: `faithfulness.md` (every measure beside its control) and
//! `faithfulness_steps.csv` (one row per analysed step).

use std::fmt::Write as _;

use super::{FaithfulnessReport, Paired};
use crate::metrics::faithfulness::episode::EpisodeResult;
use crate::metrics::sweep::MeanStd;

fn row(out: &mut String, what: &str, p: &Paired) {
    let _ = writeln!(
        out,
        "| {what} | {} | {} ({}) |",
        p.value, p.control, p.control_is
    );
}

/// A checkpoint's figures: the file's stem and what it shows. `deletion` is drawn for every
/// model, the other two for models with maps.
pub const FIGURES: [(&str, &str); 3] = [
    ("deletion", "Deletion and insertion curves"),
    (
        "rank_correlation",
        "Per-step Spearman ρ(M, Δ) beside a permuted M",
    ),
    (
        "effects",
        "Success under each closed loop and counterfactual beside the unmodified episodes",
    ),
];

impl FaithfulnessReport {
    /// The figures drawn for checkpoint `i`: `(stem, what it shows, file)`, the file
    /// `STEM.png`, or `STEM_i.png` when the report has several checkpoints; `deletion` for
    /// every model, `rank_correlation` and `effects` for one with maps ([`FIGURES`]).
    pub fn figure_files(&self, i: usize) -> Vec<(&'static str, &'static str, String)> {
        let Some(c) = self.checkpoints.get(i) else {
            return Vec::new();
        };
        let suffix = if self.checkpoints.len() == 1 {
            String::new()
        } else {
            format!("_{i}")
        };
        FIGURES
            .iter()
            .filter(|(stem, _)| *stem == "deletion" || c.variant == "attention")
            .map(|&(stem, what)| (stem, what, format!("{stem}{suffix}.png")))
            .collect()
    }

    /// What ran, in a line: the levels, seeds × episodes per seed and their product (the
    /// episodes behind each checkpoint and level), the actions.
    fn run_line(&self) -> String {
        let seeds = if self.seeds == 1 {
            "1 seed".to_owned()
        } else {
            format!("{} seeds", self.seeds)
        };
        format!(
            "Level {}, {seeds} × {} episodes per seed = {} episodes per checkpoint and level, {} actions; mean ± std over seeds. {:.1} s.",
            self.level,
            self.episodes_per_seed,
            self.seeds * self.episodes_per_seed,
            self.actions,
            self.seconds
        )
    }

    /// The report as Markdown: the verdict on each checkpoint in a sentence, what ran, then
    /// one table per checkpoint, every measure beside its control, its figures under it.
    pub fn markdown(&self) -> String {
        let mut out = "# Faithfulness\n\n".to_owned();
        for c in &self.checkpoints {
            let _ = writeln!(
                out,
                "**Verdict** (`{}`, {}): {}\n",
                c.checkpoint,
                c.level,
                super::verdict::sentence(c)
            );
        }
        let _ = writeln!(out, "{}", self.run_line());
        for (i, c) in self.checkpoints.iter().enumerate() {
            let _ = write!(
                out,
                "\n## {} ({}, {})\n\n{} episodes, {} analysed steps, success {}.\n\n| measure | value | control |\n|---|---|---|\n",
                c.checkpoint, c.variant, c.level, c.episodes, c.analysed_steps, c.success
            );
            let o = &c.occlusion;
            if let Some(p) = &o.rank_correlation {
                row(&mut out, "occlusion: Spearman ρ(M, Δ)", p);
            }
            if let Some(p) = &o.argmax_agreement {
                row(&mut out, "occlusion: argmax M = argmax Δ", p);
            }
            if let Some(p) = &o.object_agreement {
                row(&mut out, "occlusion: top-M object = top-Δ object", p);
            }
            row(
                &mut out,
                "occlusion: the target is the top-Δ object",
                &o.target_most_effective,
            );
            for (name, a) in [("deletion", &c.deletion), ("insertion", &c.insertion)] {
                let dir = if name == "deletion" {
                    "lower"
                } else {
                    "higher"
                };
                if let Some(m) = &a.by_m {
                    let _ = writeln!(
                        out,
                        "| {name} AUC, M order ({dir} = more faithful) | {m} | random {} · Δ oracle {} |",
                        a.random, a.oracle
                    );
                } else {
                    let _ = writeln!(
                        out,
                        "| {name} AUC, Δ oracle order | {} | random {} |",
                        a.oracle, a.random
                    );
                }
            }
            for (name, e) in &c.interventions {
                let _ = writeln!(
                    out,
                    "| one step, M {name}: TV distance / action flips | {} / {} | unchanged M: 0 / 0 ({} steps) |",
                    e.tv, e.flip_rate, e.steps
                );
            }
            let none = c.closed_loop.get("none");
            for (name, l) in &c.closed_loop {
                if *name == "none" {
                    continue;
                }
                let _ = writeln!(
                    out,
                    "| closed loop, {name}: success / distractor | {} / {} | unmodified {} / {} |",
                    l.success,
                    l.distractor,
                    none.map_or(MeanStd::of(&[]), |n| n.success),
                    none.map_or(MeanStd::of(&[]), |n| n.distractor)
                );
            }
            for (name, cf) in &c.counterfactuals {
                let skipped: usize = cf.skipped.values().sum();
                let _ = writeln!(
                    out,
                    "| counterfactual {name} ({} run, {skipped} skipped): argmax M tracks the named object | {} | {} ({}) |",
                    cf.ran, cf.tracking.value, cf.tracking.control, cf.tracking.control_is
                );
                row(
                    &mut out,
                    &format!("counterfactual {name}: success"),
                    &cf.success,
                );
            }
            for (kind, l) in &c.localisation {
                let k = kind.name();
                row(
                    &mut out,
                    &format!("{k} map: pointing game"),
                    &l.pointing_game,
                );
                row(
                    &mut out,
                    &format!("{k} map: relevance mass"),
                    &l.relevance_mass,
                );
                row(
                    &mut out,
                    &format!("{k} map: relevance rank accuracy"),
                    &l.rank_accuracy,
                );
            }
            out.push('\n');
            for (_, what, file) in self.figure_files(i) {
                let _ = writeln!(out, "![{what}]({file})");
            }
        }
        out
    }
}

/// One CSV row per analysed step of every checkpoint.
pub fn steps_csv(rows: &[(String, &[EpisodeResult])]) -> String {
    let mut out = crate::table::Table::new(
        "checkpoint,eval_seed,level_seed,step,rank_correlation,chance_rank_correlation,argmax_agreement,object_agreement,target_most_effective,deletion_auc_m,deletion_auc_random,deletion_auc_oracle,insertion_auc_m,insertion_auc_random,insertion_auc_oracle,tv_uniform,tv_permuted,tv_steered",
    );
    let num = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v:.6}"));
    let b = |x: Option<bool>| x.map_or(String::new(), |v| u8::from(v).to_string());
    let auc = |c: &Option<(Vec<f64>, f64)>| num(c.as_ref().map(|c| c.1));
    for (name, eps) in rows {
        for e in *eps {
            for (i, s) in e.steps.iter().enumerate() {
                let tv = |n: &str| num(s.interventions.get(n).map(|e| e.tv));
                out.push(
                    &crate::table::Record::new()
                        .field(name)
                        .field(e.eval_seed)
                        .field(e.level_seed)
                        .field(i)
                        .field(num(s.rank_correlation))
                        .field(num(s.chance_rank_correlation))
                        .field(b(s.argmax_agreement))
                        .field(b(s.object_agreement))
                        .field(b(s.target_most_effective))
                        .field(auc(&s.deletion.by_m))
                        .field(auc(&s.deletion.random))
                        .field(auc(&s.deletion.oracle))
                        .field(auc(&s.insertion.by_m))
                        .field(auc(&s.insertion.random))
                        .field(auc(&s.insertion.oracle))
                        .field(tv("uniform"))
                        .field(tv("permuted"))
                        .field(tv("steered")),
                );
            }
        }
    }
    out.finish()
}
