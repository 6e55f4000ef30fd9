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

impl FaithfulnessReport {
    /// The report as Markdown: one table per checkpoint, every measure beside its control.
    pub fn markdown(&self) -> String {
        let mut out = format!(
            "# Faithfulness\n\nLevel {}, {} seeds × {} episodes, {} actions; mean ± std over seeds. {:.1} s.\n",
            self.level, self.seeds, self.episodes_per_seed, self.actions, self.seconds
        );
        for c in &self.checkpoints {
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
