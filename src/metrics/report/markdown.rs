//! `report.md`: the evaluation's tables as Markdown, rendered from a [`Report`].

use std::fmt::Write as _;

use super::{
    Cell, EPISODES_DIR, EpisodePages, FIG6_REWARD, FIG6_SUCCESS, FIG7_OBJECT, FIG8_COLOR, Failure,
    LOW_ACC_CMB, Report,
};
use crate::metrics::failure::FailureClass;
use crate::metrics::grounding::WordKind;
use crate::metrics::sweep::MeanStd;

/// `level | grid | rooms` of a level-keyed row: a BabyAI id with its grid and room layout,
/// or the paper's level as `S{size} N{objects}` in one room of its size.
pub(crate) fn level_key(level: Option<&str>, size: usize, objects: usize) -> String {
    match level.and_then(|id| crate::env::level::LevelId::parse(id).ok()) {
        Some(id) => {
            let (grid, rooms) = id.spec().rooms.layout_names();
            format!("{} | {grid} | {rooms}", id.id())
        }
        None => format!("S{size} N{objects} | {size}×{size} | 1×1"),
    }
}

impl Report {
    /// The header cells that name a row's cell: `checkpoint`, then with BabyAI levels in the
    /// sweep ([`Report::has_levels`]) `level`, its `grid` (width × height, walls included) and
    /// `rooms` (columns × rows), as `env list` gives them; else `size` and `objects`.
    pub(crate) fn key_header(&self) -> &'static str {
        if self.has_levels() {
            "| checkpoint | level | grid | rooms |"
        } else {
            "| checkpoint | size | objects |"
        }
    }

    /// The separator cells under [`Report::key_header`].
    pub(crate) fn key_rule(&self) -> &'static str {
        if self.has_levels() {
            "|---|---|---|---|"
        } else {
            "|---|---|---|"
        }
    }

    /// The row cells of [`Report::key_header`] for `checkpoint` on `level` (a BabyAI id;
    /// `None` for the paper's level, named `S{size} N{objects}` as [`Cell::label`] does).
    fn key_cells(
        &self,
        checkpoint: &str,
        level: Option<&str>,
        size: usize,
        objects: usize,
    ) -> String {
        if self.has_levels() {
            format!("| {checkpoint} | {} |", level_key(level, size, objects))
        } else {
            format!("| {checkpoint} | {size} | {objects} |")
        }
    }

    /// [`Report::key_cells`] of a cell.
    pub(crate) fn cell_key(&self, c: &Cell) -> String {
        self.key_cells(&c.checkpoint, c.level.as_deref(), c.size, c.objects)
    }

    /// `report.md`: the summary, then the tables, each figure linked under the table it
    /// shows.
    pub fn markdown(&self, failures: &[Failure]) -> String {
        self.markdown_linked(failures, None)
    }

    /// [`Report::markdown`], each worst episode with a page among `pages` (`eval --html`)
    /// linked to it in a last column.
    pub fn markdown_linked(&self, failures: &[Failure], pages: Option<&EpisodePages>) -> String {
        let mut s = String::new();
        let figs = self.figure_names();
        let _ = writeln!(s, "# groundscope evaluation\n");
        self.summary(&mut s);
        let _ = writeln!(s, "\n## What ran\n");
        self.setup(&mut s);
        let _ = writeln!(s, "\n## Task performance (paper Fig. 6)\n");
        let _ = writeln!(
            s,
            "{} reward | success | length | reward given success |",
            self.key_header()
        );
        let _ = writeln!(s, "{}---|---|---|---|", self.key_rule());
        for c in &self.cells {
            let _ = writeln!(
                s,
                "{} {} | {} | {} | {} |",
                self.cell_key(c),
                self.over_seeds(&c.reward),
                self.over_seeds(&c.success),
                self.over_seeds(&c.length),
                self.over_seeds(&c.reward_given_success)
            );
        }
        if figs.contains(&FIG6_REWARD) {
            let _ = writeln!(
                s,
                "\n![Mean reward (Fig. 6)]({FIG6_REWARD})\n![Success rate (Fig. 6)]({FIG6_SUCCESS})"
            );
        }
        self.grounding_tables(&mut s, &figs);
        self.grounding_levels_table(&mut s);
        self.around_table(&mut s);
        self.words_table(&mut s);
        s.push_str(&self.levels_markdown());
        self.failure_table(&mut s);
        self.exploration_tables(&mut s);
        self.worst_table(&mut s, failures, pages);
        s
    }

    /// What ran: α, the action mode, seeds and episodes, the sweep's time, each checkpoint.
    fn setup(&self, s: &mut String) {
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
            // What is not known is said so, not filled in with a default.
            let line = if c.variant == "bot" {
                "minigrid's BabyAI bot (a planner that reads the full state; not trained)"
                    .to_owned()
            } else {
                let trained = match (&c.training, c.level) {
                    (Some(t), _) => t.clone(),
                    (None, Some(l)) => format!("trained on {l}"),
                    (None, None) => "training levels not known".to_owned(),
                };
                let supervised = c.ground_loss.map_or_else(String::new, |l| {
                    format!("; its maps supervised by `--ground-loss {l}`")
                });
                format!(
                    "{} model, {}, {trained}{supervised}",
                    c.variant,
                    c.frames.map_or_else(
                        || "training frames not known".to_owned(),
                        |f| format!("{f} training frames")
                    ),
                )
            };
            let _ = writeln!(s, "- `{}`: {line}", c.name);
        }
    }

    /// The grounding tables, one per word kind (door and location only where some cell's
    /// missions hold such words), the paper's Figs. 7 and 8 under theirs.
    fn grounding_tables(&self, s: &mut String, figs: &[&str]) {
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
            (WordKind::Goal, "\"goal\" maps (MiniGrid's goal cells)"),
            (WordKind::Lava, "\"lava\" maps (MiniGrid's lava cells)"),
            (WordKind::Opening, "\"opening\" maps (MiniGrid's wall gaps)"),
        ] {
            let has = |c: &super::Cell| c.accuracy.as_ref().and_then(|a| a.of(kind)).is_some();
            let optional = !matches!(
                kind,
                WordKind::Object | WordKind::Color | WordKind::Combined
            );
            if !self.cells.iter().any(has) && optional {
                continue;
            }
            let _ = writeln!(s, "\n## {title}\n");
            let _ = writeln!(
                s,
                "{} acc | acc_ng | acc_bs | acc_cmb | pointing | mass | chance: acc · acc_ng · pointing and mass | evaluated steps | episodes without |",
                self.key_header()
            );
            let _ = writeln!(s, "{}---|---|---|---|---|---|---|---|---|", self.key_rule());
            for c in &self.cells {
                let Some(g) = c.accuracy.as_ref().and_then(|a| a.of(kind)) else {
                    continue;
                };
                let chance = |i: usize| {
                    g.chance_mean(i)
                        .map_or_else(|| "–".to_owned(), |v| format!("{v:.3}"))
                };
                let _ = writeln!(
                    s,
                    "{} {} | {} | {} | {} | {} | {} | {} · {} · {} | {} | {} |",
                    self.cell_key(c),
                    self.over_seeds(&g.acc),
                    self.over_seeds(&g.acc_ng),
                    self.over_seeds(&g.acc_bs),
                    self.over_seeds(&g.acc_cmb),
                    self.over_seeds(&g.pointing),
                    self.over_seeds(&g.mass),
                    chance(0),
                    chance(1),
                    chance(4),
                    g.evaluated_steps,
                    g.episodes_without
                );
            }
            match kind {
                WordKind::Object if figs.contains(&FIG7_OBJECT) => {
                    let _ = writeln!(s, "\n![Object-word map accuracy (Fig. 7)]({FIG7_OBJECT})");
                }
                WordKind::Color if figs.contains(&FIG8_COLOR) => {
                    let _ = writeln!(s, "\n![Colour-word map accuracy (Fig. 8)]({FIG8_COLOR})");
                }
                WordKind::Location => self.region_line(s),
                _ => {}
            }
        }
    }

    /// The line under the location table: each cell's region score beside its chance.
    fn region_line(&self, s: &mut String) {
        let kind = WordKind::Location;
        let _ = writeln!(
            s,
            "\nRegion (the map's mass in the half-plane the word names, fixed at reset by the start pose): {}",
            self.cells
                .iter()
                .filter_map(|c| {
                    let g = c.accuracy.as_ref()?.of(kind)?;
                    Some(format!(
                        "{} {} (chance {})",
                        c.level.as_deref().unwrap_or(&c.checkpoint),
                        self.over_seeds(&g.region),
                        g.region_chance
                            .mean
                            .map_or_else(|| "–".into(), |v| format!("{v:.3}"))
                    ))
                })
                .collect::<Vec<_>>()
                .join("; ")
        );
    }

    /// The worst episodes: how they were chosen, then one row each with what replays it and
    /// opens it in the debugger, and its page where `pages` has one.
    fn worst_table(&self, s: &mut String, failures: &[Failure], pages: Option<&EpisodePages>) {
        let _ = writeln!(s, "\n## Worst episodes\n");
        let _ = writeln!(
            s,
            "`failed`: the `--top-k` longest failed episodes of each BabyAI level (the paper's cells \
             together). `low_acc_cmb`: the episodes whose `acc_cmb` of `M` on its visible targets is \
             under {LOW_ACC_CMB}, lowest first, at most `--top-k` per level, and none for a level \
             whose lowest are all 0 (a ranking of zeros chooses nothing). An episode at or above \
             {LOW_ACC_CMB} is not listed for its `acc_cmb`, so a success with a perfect `M` never is.\n"
        );
        if failures.is_empty() {
            let _ = writeln!(
                s,
                "None: no episode failed, and none had an `acc_cmb` under {LOW_ACC_CMB}."
            );
            return;
        }
        let skipped = failures
            .iter()
            .filter(|f| f.counterfactual_skipped.is_some())
            .count();
        if skipped > 0 {
            let _ = writeln!(
                s,
                "{skipped} failed episode(s) could not be re-run without distractors (\"not built\" below, with the reason); the sweep kept them.\n"
            );
        }
        let (page_header, page_rule) = match pages {
            Some(_) => (" page |", "---|"),
            None => ("", ""),
        };
        let _ = writeln!(
            s,
            "| why {} seed | mission | reward | length | acc_cmb (M) | class (behaviour) | without distractors | replay · open in the debugger |{page_header}",
            self.key_header()
        );
        let _ = writeln!(
            s,
            "|---{}---|---|---|---|---|---|---|---|{page_rule}",
            self.key_rule()
        );
        for f in failures {
            let page = match pages {
                Some(p) if p.has(&f.page_name()) => {
                    format!(
                        " [open]({EPISODES_DIR}/{}#step={}) |",
                        f.page_name(),
                        f.opening_step()
                    )
                }
                Some(_) => " – |".to_owned(),
                None => String::new(),
            };
            let _ = writeln!(
                s,
                "| {} {} {} | {} | {:.3} | {} | {} | {} | {} | `{}` · `{}` |{page}",
                f.kind,
                self.key_cells(&f.checkpoint, f.level.as_deref(), f.size, f.objects),
                f.seed,
                f.mission,
                f.reward,
                f.length,
                f.acc_cmb.map_or("–".into(), |a| format!("{a:.3}")),
                f.class.map_or("–".into(), |c| match f.behaviour {
                    Some(b) if b != c => format!("{} ({})", c.name(), b.name()),
                    _ => c.name().to_owned(),
                }),
                match (f.counterfactual, &f.counterfactual_skipped) {
                    (Some(c), _) => format!(
                        "{} ({} removed, {} steps)",
                        if c.success { "succeeds" } else { "fails" },
                        c.distractors_removed,
                        c.length
                    ),
                    (None, Some(why)) => format!("not built: {}", why.replace('|', "/")),
                    (None, None) => "–".into(),
                },
                f.replay,
                f.view_command()
            );
        }
    }

    /// A mean ± std over this report's evaluation seeds as its tables show it: the mean alone
    /// for one seed, whose std of 0 is no measured spread ([`MeanStd::shown`]).
    pub(super) fn over_seeds(&self, m: &MeanStd) -> String {
        m.shown(self.seeds != 1)
    }

    /// The failure-class table of `report.md`: one row per cell, `–` where a class cannot be
    /// decided (grounding for baselines).
    fn failure_table(&self, s: &mut String) {
        let _ = writeln!(s, "\n## Failure classes\n");
        // BabyAI's mechanics' classes and MiniGrid's own only where some cell could have
        // them; MiniGrid's first, as they are decided first.
        let classes: Vec<FailureClass> = FailureClass::MINIGRID
            .into_iter()
            .chain(FailureClass::ALL)
            .filter(|k| {
                let occasional = FailureClass::MECHANICS.contains(k) || k.is_minigrid();
                !occasional || self.cells.iter().any(|c| c.failure_classes.contains_key(k))
            })
            .collect();
        let mut header = format!("{} failed |", self.key_header());
        for &c in &classes {
            let _ = write!(header, " {} |", c.label());
        }
        let _ = writeln!(s, "{header}");
        let _ = writeln!(s, "{}---|{}", self.key_rule(), "---|".repeat(classes.len()));
        for c in &self.cells {
            let _ = write!(
                s,
                "{} {} |",
                self.cell_key(c),
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
        self.behaviour_table(s);
        let _ = writeln!(
            s,
            "\nEach failed episode gets the first class whose rule holds, in the columns' order              (docs/evaluation.md#failure-classes):\n"
        );
        for k in &classes {
            let _ = writeln!(s, "- `{}`: {}.", k.name(), k.definition());
        }
    }

    /// What the failed agents were doing, whatever their class: a behaviour per failed
    /// episode ([`crate::metrics::failure::Diagnosis::behaviour`]), counted per cell.
    fn behaviour_table(&self, s: &mut String) {
        if self.cells.iter().all(|c| c.behaviours.is_empty()) {
            return;
        }
        let _ = writeln!(s, "\n### What the agent was doing\n");
        let behaviours = FailureClass::BEHAVIOURS;
        let mut header = format!("{} failed |", self.key_header());
        for b in behaviours {
            let _ = write!(header, " {} |", b.name().replace('_', " "));
        }
        let _ = writeln!(s, "{header} none of these |");
        let _ = writeln!(
            s,
            "{}---|{}---|",
            self.key_rule(),
            "---|".repeat(behaviours.len())
        );
        for c in &self.cells {
            let n = |name: &str| c.behaviours.get(name).copied().unwrap_or(0);
            let _ = write!(
                s,
                "{} {} |",
                self.cell_key(c),
                c.behaviours.values().sum::<u64>()
            );
            for b in behaviours {
                let _ = write!(s, " {} |", n(b.name()));
            }
            let _ = writeln!(s, " {} |", n("none"));
        }
        let _ = writeln!(
            s,
            "\nThe first behaviour that holds, in the columns' order:\n"
        );
        for b in behaviours {
            let _ = writeln!(s, "- `{}`: {}.", b.name(), b.definition());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Cell, Report, SCHEMA_VERSION};
    use crate::metrics::sweep::{MeanStd, Performance};

    fn cell(level: Option<&str>, size: usize, objects: usize, success: f64) -> Cell {
        let m = MeanStd {
            mean: Some(success),
            std: Some(0.0),
        };
        let perf = Performance {
            reward: m,
            success: m,
            length: m,
            reward_given_success: m,
        };
        Cell::new("ck", "baseline", size, objects, 4, &perf, None)
            .with_level(level.map(str::to_owned))
    }

    fn report(cells: Vec<Cell>) -> Report {
        Report {
            schema_version: SCHEMA_VERSION,
            groundscope_version: String::new(),
            alpha: 0.5,
            mode: "greedy".into(),
            seeds: 2,
            first_seed: 0,
            episodes_per_seed: 2,
            saliency: false,
            checkpoints: Vec::new(),
            cells,
            elapsed_secs: 0.0,
        }
    }

    #[test]
    fn babyai_levels_of_one_room_size_get_rows_of_their_own() {
        let r = report(vec![
            cell(None, 8, 4, 0.5),
            cell(Some("BabyAI-GoToLocal-v0"), 8, 0, 0.25),
            cell(Some("BabyAI-PickupLoc-v0"), 8, 0, 0.75),
        ]);
        let md = r.markdown(&[]);
        for row in [
            "| ck | S8 N4 | 8×8 | 1×1 | 0.500 ± 0.000 |",
            "| ck | BabyAI-GoToLocal-v0 | 8×8 | 1×1 | 0.250 ± 0.000 |",
            "| ck | BabyAI-PickupLoc-v0 | 8×8 | 1×1 | 0.750 ± 0.000 |",
        ] {
            // The performance table names every cell by its level.
            assert!(md.contains(row), "{row}\n{md}");
        }
        assert!(md.contains("| checkpoint | level | grid | rooms | reward |"));
        assert!(md.contains("| checkpoint | level | grid | rooms | failed |"));
        let csv = r.performance_csv();
        let (header, rows) = crate::table::read(&csv).unwrap();
        assert_eq!(header.last().map(String::as_str), Some("level"));
        let levels: Vec<&str> = rows.iter().map(|r| r[r.len() - 1].as_str()).collect();
        assert_eq!(levels, ["", "BabyAI-GoToLocal-v0", "BabyAI-PickupLoc-v0"]);
        assert!(rows.iter().all(|r| r.len() == header.len()));
    }

    #[test]
    fn one_seed_shows_means_alone_and_several_their_spread() {
        let mut r = report(vec![cell(None, 8, 4, 0.5)]);
        r.seeds = 1;
        let md = r.markdown(&[]);
        assert!(
            md.contains("| ck | 8 | 4 | 0.500 | 0.500 | 0.500 | 0.500 |"),
            "{md}"
        );
        assert!(!md.contains('±'), "{md}");
        r.seeds = 2;
        let md = r.markdown(&[]);
        assert!(
            md.contains("| ck | 8 | 4 | 0.500 ± 0.000 | 0.500 ± 0.000 |"),
            "{md}"
        );
    }

    #[test]
    fn the_paper_levels_tables_name_cells_by_size_and_objects_alone() {
        let r = report(vec![cell(None, 8, 4, 0.5), cell(None, 6, 2, 0.25)]);
        let md = r.markdown(&[]);
        assert!(
            md.contains("| checkpoint | size | objects | reward |"),
            "{md}"
        );
        assert!(md.contains("| ck | 6 | 2 | 0.250 ± 0.000 |"), "{md}");
        assert!(!md.contains("| level |"), "{md}");
        assert!(
            r.performance_csv()
                .starts_with("checkpoint,variant,size,objects,episodes,")
        );
        assert!(!r.performance_csv().contains(",level"));
    }
}
