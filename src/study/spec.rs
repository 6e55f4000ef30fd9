//! A study's spec (`study.toml`) and the runs it plans.
//!
//! ```toml
//! seeds = [1, 2, 3]
//! frames = 500000
//! eval = ["--first-seed", "1500", "--seeds", "3", "--episodes", "100"]
//! faithfulness = ["--episodes", "20"]          # optional
//!
//! [recipes]                                     # named sets of `train` flags
//! ppo = ["--model", "attention"]
//! ent = ["--model", "attention", "--entropy-coef", "0.001"]
//!
//! [levels]                                      # named level sets
//! paper = "paper"                               # the paper's level (eval: --sizes 8 --objects 4)
//! goto = "BabyAI-GoToLocal-v0"                  # a BabyAI id: --level ID for train and eval
//! mix = { train = ["--levels", "BabyAI-GoToLocal-v0,BabyAI-PickupLoc-v0:2"] }
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use super::{MANIFEST_FORMAT, Manifest, PlannedRun, StudyError, one_line, run_hash, shown};

/// The longest name of a recipe or a level set: a run's directory, `RECIPE-LEVELS-sSEED`,
/// stays within the 255 bytes a file name may have.
const NAME_MAX: usize = 100;

/// `study.toml`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudySpec {
    /// Training seeds: every recipe on every level set from each.
    pub seeds: Vec<u64>,
    /// Frames each run trains for (`train --frames`).
    pub frames: u64,
    /// Flags of the `eval` that follows each training (its checkpoint, output directory and
    /// levels are the run's).
    #[serde(default)]
    pub eval: Vec<String>,
    /// Flags of a `faithfulness` run after the evaluation; absent: none.
    #[serde(default)]
    pub faithfulness: Option<Vec<String>>,
    /// Named sets of `train` flags.
    pub recipes: BTreeMap<String, Vec<String>>,
    /// Named level sets.
    pub levels: BTreeMap<String, LevelSet>,
}

/// A level set: `"paper"`, a BabyAI id, or the flags of `train` (`--level`, `--levels`) and
/// optionally of `eval`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum LevelSet {
    /// `"paper"` or a registered id.
    Named(String),
    /// Explicit flags.
    Flags {
        /// Flags `train` takes for the levels.
        train: Vec<String>,
        /// Flags `eval` takes for them (default: the same `--level`/`--levels`, weights
        /// dropped; the paper's 8×8 room with 4 objects where `train` names none).
        #[serde(default)]
        eval: Option<Vec<String>>,
    },
}

/// Flags the plan owns: a recipe, a level set or a step that gives one is refused by name.
const OWNED_TRAIN: [&str; 6] = [
    "--out", "--seed", "--frames", "--resume", "--quiet", "--help",
];
const OWNED_STEP: [&str; 5] = [
    "--out",
    "--checkpoint",
    "--quiet",
    "--help",
    "--levels-file",
];

impl LevelSet {
    fn train_flags(&self) -> Vec<String> {
        match self {
            Self::Named(n) if n == "paper" => Vec::new(),
            Self::Named(id) => vec!["--level".into(), id.clone()],
            Self::Flags { train, .. } => train.clone(),
        }
    }

    fn eval_flags(&self) -> Vec<String> {
        if let Self::Flags { eval: Some(e), .. } = self {
            return e.clone();
        }
        let train = self.train_flags();
        // `--level ID` or `--levels A,B:2` (the weights are training's alone).
        for (i, f) in train.iter().enumerate() {
            if (f == "--level" || f == "--levels")
                && let Some(v) = train.get(i + 1)
            {
                let ids: Vec<&str> = v
                    .split(',')
                    .map(|x| x.split(':').next().unwrap_or(x).trim())
                    .collect();
                return vec!["--levels".into(), ids.join(",")];
            }
        }
        vec!["--sizes".into(), "8".into(), "--objects".into(), "4".into()]
    }
}

impl StudySpec {
    /// Parses `study.toml`'s text; an error names `file` and the field.
    pub fn parse(text: &str, file: &Path) -> Result<Self, StudyError> {
        let spec: Self = toml::from_str(text)
            .map_err(|e| StudyError(format!("{}: {}", file.display(), toml_error(&e, text))))?;
        spec.check(file)?;
        Ok(spec)
    }

    fn check(&self, file: &Path) -> Result<(), StudyError> {
        let bad = |what: String| Err(StudyError(format!("{}: {what}", file.display())));
        if self.seeds.is_empty() || self.recipes.is_empty() || self.levels.is_empty() {
            return bad("seeds, recipes and levels must each name at least one".into());
        }
        if self.frames == 0 {
            return bad("frames must be at least 1".into());
        }
        let mut seen = std::collections::BTreeSet::new();
        for s in &self.seeds {
            if !seen.insert(s) {
                return bad(format!("seed {s} is listed twice"));
            }
        }
        for name in self.recipes.keys().chain(self.levels.keys()) {
            if name.is_empty()
                || !name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.')
            {
                return bad(format!(
                    "name {}: recipes and level sets are named with letters, digits, '_' and '.' (they name run directories, joined by '-')",
                    shown(name)
                ));
            }
            if name.len() > NAME_MAX {
                return bad(format!(
                    "name {}: recipes and level sets are named in at most {NAME_MAX} characters (they name run directories)",
                    shown(name)
                ));
            }
        }
        let owned = |flags: &[String], owned: &[&str], what: &str| {
            for f in flags {
                let flag = f.split('=').next().unwrap_or(f);
                if owned.contains(&flag) {
                    return bad(format!(
                        "{what} gives {flag}, which the plan sets for each run"
                    ));
                }
            }
            Ok(())
        };
        for (name, flags) in &self.recipes {
            owned(flags, &OWNED_TRAIN, &format!("recipe {name}"))?;
        }
        for (name, set) in &self.levels {
            owned(
                &set.train_flags(),
                &OWNED_TRAIN,
                &format!("level set {name}"),
            )?;
            owned(
                &set.eval_flags(),
                &OWNED_STEP,
                &format!("level set {name}'s eval"),
            )?;
        }
        owned(&self.eval, &OWNED_STEP, "eval")?;
        if let Some(f) = &self.faithfulness {
            owned(f, &OWNED_STEP, "faithfulness")?;
        }
        Ok(())
    }

    /// The manifest of study `name`, run by `binary`: one run per seed × recipe × level set,
    /// seed by seed.
    pub fn plan(&self, name: &str, binary: &str) -> Manifest {
        let mut runs = Vec::new();
        for &seed in &self.seeds {
            for (recipe, flags) in &self.recipes {
                for (levels, set) in &self.levels {
                    let run = format!("{recipe}-{levels}-s{seed}");
                    let dir = format!("runs/{run}");
                    let mut train = flags.clone();
                    train.extend(set.train_flags());
                    train.extend([
                        "--seed".into(),
                        seed.to_string(),
                        "--frames".into(),
                        self.frames.to_string(),
                        "--out".into(),
                        dir.clone(),
                        "--quiet".into(),
                    ]);
                    let step = |flags: &[String], out: &str| {
                        let mut a = vec!["--checkpoint".to_owned(), dir.clone()];
                        a.extend(set.eval_flags());
                        a.extend(flags.iter().cloned());
                        a.extend(["--out".into(), format!("{dir}/{out}"), "--quiet".into()]);
                        a
                    };
                    let eval = step(&self.eval, "eval");
                    let faithfulness = self
                        .faithfulness
                        .as_deref()
                        .map(|f| step(f, "faithfulness"));
                    let threads = threads_of(&train);
                    let mut planned = PlannedRun {
                        name: run,
                        recipe: recipe.clone(),
                        levels: levels.clone(),
                        seed,
                        train,
                        eval,
                        faithfulness,
                        threads,
                        hash: String::new(),
                    };
                    planned.hash = run_hash(&planned.name, &planned.steps());
                    runs.push(planned);
                }
            }
        }
        Manifest {
            format: MANIFEST_FORMAT.into(),
            name: name.to_owned(),
            binary: binary.to_owned(),
            runs,
        }
    }
}

/// TOML's error as one line: the line it is on and TOML's message, not the line itself (which
/// may be a whole file long), escaped and cut ([`one_line`]).
fn toml_error(e: &toml::de::Error, text: &str) -> String {
    match e.span() {
        Some(span) => {
            let before = text.get(..span.start).unwrap_or(text);
            let line = before.matches('\n').count() + 1;
            format!("line {line}: {}", one_line(e.message()))
        }
        None => one_line(&e.to_string()),
    }
}

/// `--threads N` (or `--update-threads`) of a training's flags; 1 without.
fn threads_of(train: &[String]) -> usize {
    train
        .iter()
        .position(|f| f == "--threads" || f == "--update-threads")
        .and_then(|i| train.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(1)
        .max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPEC: &str = r#"
seeds = [1, 2]
frames = 1000
eval = ["--episodes", "10"]

[recipes]
ppo = ["--model", "attention"]
ent = ["--model", "attention", "--entropy-coef", "0.001", "--threads", "2"]

[levels]
paper = "paper"
mix = { train = ["--levels", "BabyAI-GoToLocal-v0,BabyAI-PickupLoc-v0:2"] }
"#;

    #[test]
    fn a_spec_plans_one_run_per_seed_recipe_and_level_set() {
        let spec = StudySpec::parse(SPEC, Path::new("study.toml")).unwrap();
        let m = spec.plan("s", "groundscope");
        assert_eq!(m.runs.len(), 8);
        let names: Vec<&str> = m.runs.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(
            names[..4],
            ["ent-mix-s1", "ent-paper-s1", "ppo-mix-s1", "ppo-paper-s1"]
        );
        let r = m.run("ent-mix-s2").unwrap();
        assert_eq!(r.threads, 2);
        assert!(r.train.ends_with(&[
            "--seed".into(),
            "2".into(),
            "--frames".into(),
            "1000".into(),
            "--out".into(),
            "runs/ent-mix-s2".into(),
            "--quiet".into()
        ]));
        // eval reads the levels without training's weights, then the spec's flags.
        assert_eq!(
            r.eval[..6],
            [
                "--checkpoint",
                "runs/ent-mix-s2",
                "--levels",
                "BabyAI-GoToLocal-v0,BabyAI-PickupLoc-v0",
                "--episodes",
                "10"
            ]
        );
        assert!(
            m.run("ppo-paper-s1")
                .unwrap()
                .eval
                .contains(&"--sizes".into())
        );
        // The same spec plans the same manifest; a changed run is refused by name, an added one
        // is not.
        let again = spec.plan("s", "groundscope");
        assert_eq!(again, m);
        super::super::check_replan(&m, &again).unwrap();
        let more = StudySpec::parse(&SPEC.replace("[1, 2]", "[1, 2, 3]"), Path::new("x")).unwrap();
        super::super::check_replan(&m, &more.plan("s", "groundscope")).unwrap();
        let changed = StudySpec::parse(&SPEC.replace("\"10\"", "\"20\""), Path::new("x")).unwrap();
        let e = super::super::check_replan(&m, &changed.plan("s", "g"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("changes run ent-mix-s1") && e.contains("eval"),
            "{e}"
        );
    }

    #[test]
    fn bad_specs_are_refused_naming_the_file_and_field() {
        for (text, says) in [
            (SPEC.replace("seeds = [1, 2]", "seeds = []"), "at least one"),
            (SPEC.replace("[1, 2]", "[1, 1]"), "seed 1 is listed twice"),
            (
                SPEC.replace("\"--model\", \"attention\"]\nent", "\"--out\", \"x\"]\nent"),
                "recipe ppo gives --out",
            ),
            (
                SPEC.replace("eval = [", "eval = [\"--checkpoint\", \"x\", "),
                "eval gives --checkpoint",
            ),
            (
                SPEC.replace("frames = 1000", "frames = 1000\nframs = 2"),
                "frams",
            ),
            (SPEC.replace("ppo =", "\"p-o\" ="), "\"p-o\""),
            ("seeds = [1".to_owned(), "study.toml"),
        ] {
            let e = StudySpec::parse(&text, Path::new("study.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(says) && e.contains("study.toml"), "{says}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
