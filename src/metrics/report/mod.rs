//! Evaluation reports: `report.json` (versioned schema), `report.md`, CSVs, figures and the
//! list of worst episodes. Everything is written to a temporary directory first and moved into
//! place only when complete, so a failure leaves no partial report.

mod bars;
pub mod browse;
mod episodes;
mod failures;
mod html;
mod level_grounding;
mod levels;
pub(crate) mod markdown;
mod plots;
mod summary;

pub use episodes::{
    EPISODES_CSV_HEADER, EPISODES_CSV_REQUIRED, EpisodeRow, episodes_csv, read_episodes_csv,
};
pub use failures::{Failure, LOW_ACC_CMB, worst_episodes};
pub use html::{EPISODES_DIR, EpisodePages, REPORT_HTML, escape_html, report_html};
pub use level_grounding::FIG_GROUNDING_LEVELS;
pub use levels::LEVELS_SUCCESS;
pub use summary::{GROUNDS_ABOVE_CHANCE, MAX_LINES as SUMMARY_MAX_LINES};

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::error::MetricsError;
use super::exploration::CellExploration;
use super::failure::FailureClass;
use super::grounding::WordKind;
use super::sweep::{GroundingStats, MeanStd, Performance};
use crate::env::level::LevelConfig;
use crate::table::{Record, Table};

/// A figure point: x, mean, std.
type Point = (f64, f64, f64);

/// Version of the `report.json` schema.
pub const SCHEMA_VERSION: u32 = 1;

/// The paper's Fig. 6: mean reward, then success rate (the paper's level's cells).
pub const FIG6_REWARD: &str = "fig6_reward.png";
/// The paper's Fig. 6, success rate.
pub const FIG6_SUCCESS: &str = "fig6_success.png";
/// The paper's Fig. 7: the object word's four accuracies.
pub const FIG7_OBJECT: &str = "fig7_object_accuracy.png";
/// The paper's Fig. 8: the colour word's four accuracies.
pub const FIG8_COLOR: &str = "fig8_color_accuracy.png";

/// Accuracies of an attention checkpoint in one cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellAccuracy {
    /// The object-type word's map (paper Fig. 7).
    pub object: GroundingStats,
    /// The colour word's map (paper Fig. 8).
    pub color: GroundingStats,
    /// The combined map `M` on the target objects (ours).
    pub combined: GroundingStats,
    /// The object and colour words one by one ([`super::words::by_word`]).
    #[serde(default)]
    pub words: Vec<super::words::WordStats>,
    /// "door" (levels with doors in their missions only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub door: Option<GroundingStats>,
    /// Location words (levels with location phrases only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub location: Option<GroundingStats>,
    /// "goal" (MiniGrid's goal missions only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<GroundingStats>,
    /// "lava" (MiniGrid's lava missions only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lava: Option<GroundingStats>,
    /// "opening" (MiniGrid's SimpleCrossing and wall LavaGap only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub opening: Option<GroundingStats>,
}

impl CellAccuracy {
    /// The stats of one word kind, if the cell's missions hold such words.
    pub fn of(&self, kind: WordKind) -> Option<&GroundingStats> {
        match kind {
            WordKind::Object => Some(&self.object),
            WordKind::Color => Some(&self.color),
            WordKind::Combined => Some(&self.combined),
            WordKind::Door => self.door.as_ref(),
            WordKind::Location => self.location.as_ref(),
            WordKind::Goal => self.goal.as_ref(),
            WordKind::Lava => self.lava.as_ref(),
            WordKind::Opening => self.opening.as_ref(),
        }
    }

    /// The word kinds' stats, in report order: object, colour, `M`, then door and location
    /// where the cell has them.
    pub fn by_kind(&self) -> Vec<(WordKind, &GroundingStats)> {
        WordKind::ALL
            .into_iter()
            .filter_map(|k| self.of(k).map(|g| (k, g)))
            .collect()
    }
}

/// The `size` and `objects` that name a cell (and its worst episodes) on `level`: the paper's
/// level's room size and object count; for a BabyAI level its room size and 0, the level's id
/// (the cell's and the failure's `level`) telling two such levels apart.
pub fn size_and_objects(level: &LevelConfig) -> (usize, usize) {
    match level.babyai {
        Some(id) => (id.spec().rooms.room_size as usize, 0),
        None => (level.room_size, level.n_objects),
    }
}

/// One checkpoint × size × objects cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// Checkpoint name.
    pub checkpoint: String,
    /// attention or baseline.
    pub variant: String,
    /// Room size.
    pub size: usize,
    /// Object count.
    pub objects: usize,
    /// Episodes evaluated (seeds × episodes per seed).
    pub episodes: u64,
    /// Mean reward.
    pub reward: MeanStd,
    /// Success rate.
    pub success: MeanStd,
    /// Mean episode length.
    pub length: MeanStd,
    /// Mean reward of successful episodes.
    pub reward_given_success: MeanStd,
    /// Grounding accuracies (attention checkpoints only).
    pub accuracy: Option<CellAccuracy>,
    /// Failed episodes per failure class (they sum to the failures); `grounding` is absent
    /// for baselines, which have no `M` to decide it.
    #[serde(default)]
    pub failure_classes: BTreeMap<FailureClass, u64>,
    /// Failed episodes per behaviour ([`super::failure::Diagnosis::behaviour`], by name;
    /// `none` for failures that showed none of them); absent in older reports and where
    /// nothing failed.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub behaviours: BTreeMap<String, u64>,
    /// Exploration coverage of all, successful and failed episodes
    /// ([`super::exploration`]); absent in older reports.
    #[serde(default)]
    pub exploration: Option<CellExploration>,
    /// The registered BabyAI level of the cell (`eval --levels`); absent for the paper's
    /// level, which `size` and `objects` describe (for a BabyAI level they hold its room
    /// size and 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<String>,
    /// The episodes beside minigrid's bot: agreement with it, first divergence of failed
    /// episodes, path efficiency of successful ones (docs/bot.md); absent in older reports.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expert: Option<super::sweep::ExpertStats>,
    /// A BabyAI cell run in the done-action mode (`eval --done`); absent in its registered
    /// mode and for the paper's level.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub done_action_mode: bool,
}

impl Cell {
    /// The cell's level as tables name it: the BabyAI id (with `(done-action mode)` when it
    /// ran so), or `S8 N4`.
    pub fn label(&self) -> String {
        match &self.level {
            Some(id) if self.done_action_mode => format!("{id} (done-action mode)"),
            Some(id) => id.clone(),
            None => format!("S{} N{}", self.size, self.objects),
        }
    }

    /// The cell on a registered BabyAI level (none: the paper's).
    #[must_use]
    pub fn with_level(mut self, level: Option<String>) -> Self {
        self.level = level;
        self
    }

    /// A cell from its performance and accuracies.
    pub fn new(
        checkpoint: &str,
        variant: &str,
        size: usize,
        objects: usize,
        episodes: u64,
        perf: &Performance,
        accuracy: Option<CellAccuracy>,
    ) -> Self {
        Self {
            checkpoint: checkpoint.to_owned(),
            variant: variant.to_owned(),
            size,
            objects,
            episodes,
            reward: perf.reward,
            success: perf.success,
            length: perf.length,
            reward_given_success: perf.reward_given_success,
            accuracy,
            failure_classes: BTreeMap::new(),
            behaviours: BTreeMap::new(),
            exploration: None,
            level: None,
            expert: None,
            done_action_mode: false,
        }
    }

    /// The cell with its failure-class counts ([`super::failure::class_counts`]).
    #[must_use]
    pub fn with_failure_classes(mut self, counts: BTreeMap<FailureClass, u64>) -> Self {
        self.failure_classes = counts;
        self
    }

    /// The cell with its behaviour counts ([`super::failure::behaviour_counts`]).
    #[must_use]
    pub fn with_behaviours(mut self, counts: BTreeMap<Option<FailureClass>, u64>) -> Self {
        self.behaviours = counts
            .into_iter()
            .map(|(b, n)| (b.map_or("none", FailureClass::name).to_owned(), n))
            .collect();
        self
    }

    /// The cell with its exploration coverage ([`super::exploration::cell_exploration`]).
    #[must_use]
    pub fn with_exploration(mut self, exploration: CellExploration) -> Self {
        self.exploration = Some(exploration);
        self
    }
}

/// A checkpoint as the report lists it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointInfo {
    /// Name (path or bundled name).
    pub name: String,
    /// attention, baseline, or bot (minigrid's BabyAI bot, a planner).
    pub variant: String,
    /// Frames it was trained for; `null` where that is not known (an imported graph, a Python
    /// policy, the bot).
    #[serde(default)]
    pub frames: Option<u64>,
    /// The level it was trained on (the first of a mix); `null` where that is not known (a
    /// Python policy, the bot).
    #[serde(default)]
    pub level: Option<LevelConfig>,
    /// The name the model gives itself, beside its file (an imported graph's
    /// `groundscope.name`: `NAME (file.onnx)`); absent for groundscope's own checkpoints.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_name: Option<String>,
    /// How it was trained, where `level` alone would mislead (`bundled:babyai`, trained on
    /// sixteen levels; [`crate::policy::bundled::training_note`]); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub training: Option<String>,
    /// The weight of `train --ground-loss` its maps were supervised with; absent for maps
    /// learnt from the task alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground_loss: Option<f64>,
    /// A Python callable evaluated by `groundscope.evaluate`, not a file groundscope loads:
    /// its episodes cannot be re-run from the report, so `view --report` replays them
    /// read-only from their recorded actions, and never takes its name for a checkpoint's.
    /// Absent (false) for every checkpoint `eval` runs.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub python: bool,
}

/// `report.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// groundscope version.
    pub groundscope_version: String,
    /// Threshold factor α.
    pub alpha: f64,
    /// greedy or sampled.
    pub mode: String,
    /// Evaluation seeds.
    pub seeds: u64,
    /// The first evaluation seed (`eval --first-seed`; absent in older reports: 0).
    #[serde(default)]
    pub first_seed: u64,
    /// Episodes per seed.
    pub episodes_per_seed: u64,
    /// `eval --saliency`: for models without maps the failure classes read the occlusion
    /// saliency where they read `M` (absent when false).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub saliency: bool,
    /// Checkpoints evaluated.
    pub checkpoints: Vec<CheckpointInfo>,
    /// One per checkpoint × size × objects.
    pub cells: Vec<Cell>,
    /// Wall time of the sweep.
    pub elapsed_secs: f64,
}

#[cfg(test)]
impl Report {
    /// A one-seed greedy report of `cells`, `episodes_per_seed` episodes each, for unit tests.
    pub(crate) fn of_cells(cells: Vec<Cell>, episodes_per_seed: u64) -> Self {
        Self {
            schema_version: SCHEMA_VERSION,
            groundscope_version: String::new(),
            alpha: 0.5,
            mode: "greedy".into(),
            seeds: 1,
            first_seed: 0,
            episodes_per_seed,
            saliency: false,
            checkpoints: Vec::new(),
            cells,
            elapsed_secs: 0.0,
        }
    }
}

impl Report {
    /// Whether some cell is on a registered BabyAI level (`eval --levels`): `size` and
    /// `objects` do not tell two such levels apart, so the tables and CSVs that name cells by
    /// them gain a `level` column (absent otherwise, so that the paper's sweeps read as before).
    pub fn has_levels(&self) -> bool {
        self.level_cells().next().is_some()
    }

    /// `columns` with a `level` column after them when the sweep has BabyAI levels.
    pub(crate) fn csv_header(&self, columns: &str) -> String {
        if self.has_levels() {
            format!("{columns},level")
        } else {
            columns.to_owned()
        }
    }

    /// `r` with the cell's BabyAI id (empty for the paper's level) appended when the sweep has
    /// BabyAI levels ([`Report::csv_header`]).
    pub(crate) fn csv_level(&self, r: Record, c: &Cell) -> Record {
        if self.has_levels() {
            r.field(c.level.as_deref().unwrap_or_default())
        } else {
            r
        }
    }

    /// `performance.csv`.
    pub fn performance_csv(&self) -> String {
        let mut t = Table::new(&self.csv_header(
            "checkpoint,variant,size,objects,episodes,reward_mean,reward_std,success_mean,success_std,length_mean,length_std,reward_given_success_mean,reward_given_success_std",
        ));
        for c in &self.cells {
            t.push(
                &self.csv_level(
                    Record::new()
                        .field(&c.checkpoint)
                        .field(&c.variant)
                        .field(c.size)
                        .field(c.objects)
                        .field(c.episodes)
                        .mean_std(&c.reward)
                        .mean_std(&c.success)
                        .mean_std(&c.length)
                        .mean_std(&c.reward_given_success),
                    c,
                ),
            );
        }
        t.finish()
    }

    /// `accuracy.csv`: one line per attention cell and word kind.
    pub fn accuracy_csv(&self) -> String {
        let mut t = Table::new(&self.csv_header(
            "checkpoint,size,objects,word,acc_mean,acc_std,acc_ng_mean,acc_ng_std,acc_bs_mean,acc_bs_std,acc_cmb_mean,acc_cmb_std,evaluated_steps,episodes_without,pointing_mean,pointing_std,mass_mean,mass_std,chance_acc,chance_acc_ng,chance_acc_bs,chance_acc_cmb,chance_pointing,chance_mass,region_mean,region_std,chance_region",
        ));
        for c in &self.cells {
            let Some(a) = &c.accuracy else { continue };
            for (kind, g) in a.by_kind() {
                t.push(
                    &self.csv_level(
                        Record::new()
                            .field(&c.checkpoint)
                            .field(c.size)
                            .field(c.objects)
                            .field(kind.name())
                            .mean_std(&g.acc)
                            .mean_std(&g.acc_ng)
                            .mean_std(&g.acc_bs)
                            .mean_std(&g.acc_cmb)
                            .field(g.evaluated_steps)
                            .field(g.episodes_without)
                            .mean_std(&g.pointing)
                            .mean_std(&g.mass)
                            .extend((0..6).fold(Record::new(), |r, i| r.field(g.chance_cell(i))))
                            .mean_std(&g.region)
                            .field(
                                g.region_chance
                                    .mean
                                    .map_or_else(String::new, |v| format!("{v:.6}")),
                            ),
                        c,
                    ),
                );
            }
        }
        t.finish()
    }

    /// The figures [`Report::write`] draws for this report, in no particular order; `report.md`
    /// links each under the table it shows.
    pub fn figure_names(&self) -> Vec<&'static str> {
        // The paper's figures plot the paper's level over room sizes and object counts; BabyAI
        // levels get their own figures.
        let paper = |c: &Cell| c.level.is_none();
        let mut figs = Vec::new();
        if self.has_levels() {
            figs.push(LEVELS_SUCCESS);
        }
        if self.has_grounding_levels() {
            figs.push(FIG_GROUNDING_LEVELS);
        }
        if self.cells.iter().any(paper) {
            figs.extend([FIG6_REWARD, FIG6_SUCCESS]);
        }
        if self.cells.iter().any(|c| paper(c) && c.accuracy.is_some()) {
            figs.extend([FIG7_OBJECT, FIG8_COLOR]);
        }
        if self.cells.iter().any(|c| c.exploration.is_some()) {
            figs.push(super::exploration::FIG_EXPLORATION);
        }
        if self
            .cells
            .iter()
            .any(|c| c.exploration.as_ref().is_some_and(|x| x.all.maps.is_some()))
        {
            figs.push(super::exploration::FIG_EXPLORATION_MAPS);
        }
        figs
    }

    /// Writes every file into `dir` (created if needed) through a [`crate::files::StagedDir`]:
    /// all of them appear together, or none. `episodes` is `episodes.csv` ([`episodes_csv`]).
    pub fn write(
        &self,
        dir: &Path,
        failures: &[Failure],
        episodes: &str,
    ) -> Result<(), MetricsError> {
        self.write_with_pages(dir, failures, episodes, None)
    }

    /// [`Report::write`], and with `pages` (`eval --html`) also `report.html` ([`REPORT_HTML`],
    /// its figures inline) and the episode pages in [`EPISODES_DIR`], each worst episode's row
    /// linking its page in both `report.md` and `report.html`. Without `pages`, an earlier
    /// run's `report.html` and pages are removed, as its figures are.
    pub fn write_with_pages(
        &self,
        dir: &Path,
        failures: &[Failure],
        episodes: &str,
        pages: Option<&EpisodePages>,
    ) -> Result<(), MetricsError> {
        let io = |p: &Path, e: std::io::Error| MetricsError::Io {
            path: p.to_path_buf(),
            reason: e.to_string(),
        };
        let staged = crate::files::StagedDir::new(dir).map_err(staged_err)?;
        let markdown = self.markdown_linked(failures, pages);
        // Plain data with string keys cannot fail to serialise.
        let files: Vec<(&str, String)> = vec![
            (
                "report.json",
                serde_json::to_string_pretty(self).unwrap_or_default(),
            ),
            (
                "failures.json",
                serde_json::to_string_pretty(failures).unwrap_or_default(),
            ),
            ("report.md", markdown.clone()),
            ("performance.csv", self.performance_csv()),
            ("accuracy.csv", self.accuracy_csv()),
            ("around.csv", self.around_csv()),
            ("words.csv", self.words_csv()),
            ("exploration.csv", self.exploration_csv()),
            ("episodes.csv", episodes.to_owned()),
        ];
        for (name, text) in &files {
            staged.write(name, text.as_bytes()).map_err(staged_err)?;
        }
        let figs = self.figure_names();
        self.draw_figures(&staged, &figs)?;
        // report.html inlines the figures just drawn: it reads nothing an earlier run left.
        let pages_dir = staged.path(EPISODES_DIR);
        if let Some(pages) = pages {
            html::stage_pages(&staged, dir, &markdown, pages)?;
        }
        // A directory reused from an evaluation with attention checkpoints must not keep
        // that run's accuracy figures beside this run's report.
        for stale in [
            FIG6_REWARD,
            FIG6_SUCCESS,
            LEVELS_SUCCESS,
            FIG_GROUNDING_LEVELS,
            FIG7_OBJECT,
            FIG8_COLOR,
            super::exploration::FIG_EXPLORATION,
            super::exploration::FIG_EXPLORATION_MAPS,
        ] {
            if !figs.contains(&stale) {
                let p = dir.join(stale);
                if p.exists() {
                    std::fs::remove_file(&p).map_err(|e| io(&p, e))?;
                }
            }
        }
        // The pages go in first, as `eval --export-failures`'s recordings do: a directory
        // of the user's own files at `episodes/` keeps them beside this run's pages.
        html::put_pages_in_place(
            pages.is_some().then_some(pages_dir.as_path()),
            &dir.join(EPISODES_DIR),
        )?;
        // A reused directory keeps no figure or table an earlier run wrote and this one did
        // not (fig7/fig8 without an attention model, report.html without --html).
        let names: Vec<&str> = files.iter().map(|(n, _)| *n).collect();
        staged
            .commit_owned(|n| {
                names.contains(&n)
                    || n == REPORT_HTML
                    || n == LEVELS_SUCCESS
                    || (n.starts_with("fig")
                        && Path::new(n).extension().is_some_and(|e| e == "png"))
            })
            .map_err(staged_err)?;
        Ok(())
    }

    /// Draws the figures `figs` names ([`Report::figure_names`]) into `staged`.
    fn draw_figures(
        &self,
        staged: &crate::files::StagedDir,
        figs: &[&str],
    ) -> Result<(), MetricsError> {
        let paper = |c: &Cell| c.level.is_none();
        if figs.contains(&LEVELS_SUCCESS) {
            self.levels_figure(&staged.path(LEVELS_SUCCESS))?;
        }
        if figs.contains(&FIG_GROUNDING_LEVELS) {
            self.grounding_levels_figure(&staged.path(FIG_GROUNDING_LEVELS))?;
        }
        if figs.contains(&FIG6_REWARD) {
            self.figure_of(
                &staged.path(FIG6_REWARD),
                "Mean reward (Fig. 6)",
                &paper,
                &|c| vec![(c.checkpoint.clone(), c.reward)],
            )?;
            self.figure_of(
                &staged.path(FIG6_SUCCESS),
                "Success rate (Fig. 6)",
                &paper,
                &|c| vec![(c.checkpoint.clone(), c.success)],
            )?;
        }
        if figs.contains(&FIG7_OBJECT) {
            self.accuracy_figures(staged, &paper)?;
        }
        // The exploration figures are drawn on the conditions `figure_names` names them on.
        let drawn = self.exploration_figures(staged.dir())?;
        debug_assert!(drawn.iter().all(|f| figs.contains(f)), "{drawn:?}");
        Ok(())
    }
}

fn staged_err(e: crate::files::PathError) -> MetricsError {
    MetricsError::Io {
        path: e.path,
        reason: e.reason,
    }
}
