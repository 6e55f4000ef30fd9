//! Where each word's map passes τ around its objects (beyond the paper): `around.csv` and a
//! table in `report.md`, from the rates at the [`AROUND`] offsets that every grounding
//! evaluation carries. `acc` and `acc_ng` say whether a map hits an object or its
//! neighbourhood; these say which side of the object a map that misses it settled on.

use std::fmt::Write;

use super::grounding::{AROUND, AROUND_NAMES, WordKind};
use super::report::Report;
use super::sweep::GroundingStats;
use crate::table::{Record, Table};

impl Report {
    /// The attention cells' grounding stats per word kind, in report order.
    fn around_rows(
        &self,
    ) -> impl Iterator<Item = (&super::report::Cell, WordKind, &GroundingStats)> {
        self.cells.iter().flat_map(|c| {
            c.accuracy
                .iter()
                .flat_map(move |a| a.by_kind().into_iter().map(move |(kind, g)| (c, kind, g)))
        })
    }

    /// `around.csv`: one line per attention cell, word kind and offset (`dx` right, `dy`
    /// back, as seen from the agent), mean and std over seeds.
    pub fn around_csv(&self) -> String {
        let mut t =
            Table::new(&self.csv_header("checkpoint,size,objects,word,offset,dx,dy,mean,std"));
        for (c, kind, g) in self.around_rows() {
            for ((name, (dx, dy)), m) in AROUND_NAMES.iter().zip(AROUND).zip(&g.around) {
                t.push(
                    &self.csv_level(
                        Record::new()
                            .field(&c.checkpoint)
                            .field(c.size)
                            .field(c.objects)
                            .field(kind.name())
                            .field(name)
                            .field(dx)
                            .field(dy)
                            .mean_std(m),
                        c,
                    ),
                );
            }
        }
        t.finish()
    }

    /// The `report.md` section: one row per attention cell and word kind, one column per
    /// offset (the mean over seeds).
    pub(super) fn around_table(&self, s: &mut String) {
        if !self.cells.iter().any(|c| c.accuracy.is_some()) {
            return;
        }
        let _ = writeln!(
            s,
            "\n## Where the maps pass τ around their objects (not in the paper)\n"
        );
        let _ = writeln!(
            s,
            "Share of related objects whose cell at each offset (as the agent sees it) passes τ; \
             `on` is `acc`, `forward` is `acc_bs`. Mean over seeds; `around.csv` has the std. \
             Every offset of a row is read on the same evaluated steps, counted in the last column.\n"
        );
        let _ = writeln!(
            s,
            "{} word | {} | evaluated steps |",
            self.key_header(),
            AROUND_NAMES.join(" | ")
        );
        let _ = writeln!(
            s,
            "{}---|{}---|",
            self.key_rule(),
            "---|".repeat(AROUND.len())
        );
        for (c, kind, g) in self.around_rows() {
            let cols: Vec<String> = g
                .around
                .iter()
                .map(|m| m.mean.map_or("–".into(), |v| format!("{v:.3}")))
                .collect();
            let _ = writeln!(
                s,
                "{} {} | {} | {} |",
                self.cell_key(c),
                kind.name(),
                cols.join(" | "),
                g.evaluated_steps
            );
        }
    }
}
