//! `report.md`: the evaluation's tables as Markdown, rendered from a [`Report`].

use std::fmt::Write as _;

use super::{Failure, Report};
use crate::metrics::failure::FailureClass;
use crate::metrics::grounding::WordKind;

impl Report {
    /// `report.md`: the tables.
    pub fn markdown(&self, failures: &[Failure]) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# groundscope evaluation\n");
        let _ = writeln!(
            s,
            "α = {}, {} actions, {} (from {}) × {} episodes per cell; {}. Sweep took {:.1} s.\n",
            self.alpha,
            self.mode,
            if self.seeds == 1 {
                "1 seed".to_owned()
            } else {
                format!("{} seeds", self.seeds)
            },
            self.first_seed,
            self.episodes_per_seed,
            // One seed has no spread: its cells give the mean alone.
            if self.seeds == 1 {
                "one seed, so no std: each cell is that seed's mean"
            } else {
                "mean ± std over seeds"
            },
            self.elapsed_secs
        );
        for c in &self.checkpoints {
            let _ = writeln!(
                s,
                "- `{}`: {} model, {} training frames, trained on {}",
                c.name, c.variant, c.frames, c.level
            );
        }
        let _ = writeln!(s, "\n## Task performance (paper Fig. 6)\n");
        let _ = writeln!(
            s,
            "| checkpoint | size | objects | reward | success | length | reward given success |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|");
        for c in &self.cells {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} |",
                c.checkpoint,
                c.size,
                c.objects,
                c.reward,
                c.success,
                c.length,
                c.reward_given_success
            );
        }
        for (kind, title) in [
            (WordKind::Object, "Object-word maps (paper Fig. 7)"),
            (WordKind::Color, "Colour-word maps (paper Fig. 8)"),
            (
                WordKind::Combined,
                "Combined map M on the target objects (not in the paper)",
            ),
            (WordKind::Door, "\"door\" maps (BabyAI's door levels)"),
            (
                WordKind::Location,
                "Location-word maps (BabyAI's Loc levels)",
            ),
        ] {
            let has = |c: &super::Cell| c.accuracy.as_ref().and_then(|a| a.of(kind)).is_some();
            if !self.cells.iter().any(has) && matches!(kind, WordKind::Door | WordKind::Location) {
                continue;
            }
            let _ = writeln!(s, "\n## {title}\n");
            let _ = writeln!(
                s,
                "| checkpoint | size | objects | acc | acc_ng | acc_bs | acc_cmb | evaluated steps | episodes without |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
            for c in &self.cells {
                let Some(g) = c.accuracy.as_ref().and_then(|a| a.of(kind)) else {
                    continue;
                };
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    c.checkpoint,
                    c.size,
                    c.objects,
                    g.acc,
                    g.acc_ng,
                    g.acc_bs,
                    g.acc_cmb,
                    g.evaluated_steps,
                    g.episodes_without
                );
            }
        }
        self.around_table(&mut s);
        self.words_table(&mut s);
        self.failure_table(&mut s);
        self.exploration_tables(&mut s);
        let _ = writeln!(s, "\n## Worst episodes\n");
        let _ = writeln!(
            s,
            "| why | checkpoint | size | objects | seed | mission | reward | length | acc_cmb (M) | class | without distractors | replay · open in the debugger |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|");
        for f in failures {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {:.3} | {} | {} | {} | {} | `{}` · `{}` |",
                f.kind,
                f.checkpoint,
                f.size,
                f.objects,
                f.seed,
                f.mission,
                f.reward,
                f.length,
                f.acc_cmb.map_or("–".into(), |a| format!("{a:.3}")),
                f.class.map_or("–", FailureClass::name),
                f.counterfactual.map_or("–".into(), |c| format!(
                    "{} ({} removed, {} steps)",
                    if c.success { "succeeds" } else { "fails" },
                    c.distractors_removed,
                    c.length
                )),
                f.replay,
                f.view_command()
            );
        }
        if self.seeds == 1 {
            // Every std of one seed is 0: a "± 0.000" would read as a measured spread.
            s = s.replace(" ± 0.000", "");
        }
        s
    }

    /// The failure-class table of `report.md`: one row per cell, `–` where a class cannot be
    /// decided (grounding for baselines).
    fn failure_table(&self, s: &mut String) {
        s.push_str(&self.levels_markdown());
        let _ = writeln!(s, "\n## Failure classes\n");
        // BabyAI's mechanics' classes only where some cell could have them.
        let classes: Vec<FailureClass> = FailureClass::ALL
            .into_iter()
            .filter(|k| {
                !FailureClass::MECHANICS.contains(k)
                    || self.cells.iter().any(|c| c.failure_classes.contains_key(k))
            })
            .collect();
        let mut header = String::from("| checkpoint | size | objects | failed |");
        for &c in &classes {
            let _ = write!(header, " {} |", c.name().replace('_', " "));
        }
        let _ = writeln!(s, "{header}");
        let _ = writeln!(s, "|---|---|---|---|{}", "---|".repeat(classes.len()));
        for c in &self.cells {
            let _ = write!(
                s,
                "| {} | {} | {} | {} |",
                c.checkpoint,
                c.size,
                c.objects,
                c.failure_classes.values().sum::<u64>()
            );
            for k in &classes {
                match c.failure_classes.get(k) {
                    Some(n) => {
                        let _ = write!(s, " {n} |");
                    }
                    None => s.push_str(" – |"),
                }
            }
            s.push('\n');
        }
    }
}
