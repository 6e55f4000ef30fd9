//! `groundscope study plan SPEC --out STUDY`: the spec's grid (`groundscope::study::StudySpec`)
//! turned into typed runs — each run's steps written as the flags of the commands they are,
//! then parsed and checked by those commands' own definitions, once — and written whole, with
//! the lines the engines run.

use std::path::Path;

use anyhow::Context as _;
use groundscope::files::read_regular_to_string;
use groundscope::study::{
    Cell, LevelSet, Manifest, PAPER, PlannedRun, SLURM_LOGS, StudySpec, check_replan,
};

use crate::ExitStatus;

/// The files a plan writes, in the order they are moved into place (the manifest last).
const PLAN_FILES: [&str; 5] = [
    "study.toml",
    "commands.txt",
    "slurm.sbatch",
    "ray_driver.py",
    "manifest.json",
];

/// Flags the plan owns for a training: a recipe or a level set that gives one is refused by
/// name.
const OWNED_TRAIN: [&str; 6] = [
    "--out", "--seed", "--frames", "--resume", "--quiet", "--help",
];

/// Flags the plan owns for an evaluation or a faithfulness run.
const OWNED_STEP: [&str; 5] = [
    "--out",
    "--checkpoint",
    "--quiet",
    "--help",
    "--levels-file",
];

pub(super) fn plan(spec_path: &Path, out: &Path) -> anyhow::Result<ExitStatus> {
    let text = read_regular_to_string(spec_path)
        .with_context(|| format!("reading {}", spec_path.display()))?;
    let spec = StudySpec::parse(&text, spec_path)?;
    check_owned(&spec, spec_path)?;
    if out.exists() && !out.is_dir() {
        anyhow::bail!("--out {}: not a directory", out.display());
    }
    let existing = out.join("manifest.json").exists();
    // Every file is written into a hidden directory of --out and moved into place only when
    // all are: a failed plan leaves the study as it was (and no --out it created).
    let staged =
        groundscope::files::StagedDir::new(out).map_err(|e| anyhow::anyhow!("--out {e}"))?;
    plan_into(&spec, &text, spec_path, out, existing, staged)
}

fn plan_into(
    spec: &StudySpec,
    text: &str,
    spec_path: &Path,
    out: &Path,
    existing: bool,
    staged: groundscope::files::StagedDir,
) -> anyhow::Result<ExitStatus> {
    let study = std::fs::canonicalize(out).with_context(|| format!("{}", out.display()))?;
    // Both paths go into every file of the plan: one that a file cannot carry (a newline, a
    // path Slurm misreads) is refused before anything is written.
    groundscope::study::study_path(&study, "--out")?;
    let name = study
        .file_name()
        .map_or_else(|| "study".to_owned(), |n| n.to_string_lossy().into_owned());
    let exe = std::env::current_exe()
        .and_then(std::fs::canonicalize)
        .context("finding this binary's path")?;
    let binary = groundscope::study::carried(&exe, "this binary's path")?.to_owned();
    let manifest = Manifest::new(&name, &binary, runs(spec, spec_path)?);
    for warning in misplaced_parents(&manifest, &study) {
        eprintln!("groundscope: warning: {warning}");
    }
    if existing {
        let old = super::study_legacy::read_manifest(&study, false)?;
        check_replan(&old, &manifest)?;
    }
    // Each file lands where a regular file (or nothing) is: a directory in the way is refused
    // before any file moves.
    for file in PLAN_FILES {
        let path = study.join(file);
        if path.is_dir() {
            anyhow::bail!("{}: is a directory", path.display());
        }
    }
    let logs = study.join(SLURM_LOGS);
    if logs.exists() && !logs.is_dir() {
        anyhow::bail!(
            "{}: not a directory (slurm.sbatch writes its logs there)",
            logs.display()
        );
    }
    for (file, bytes) in [
        ("study.toml", text.to_owned()),
        ("commands.txt", manifest.commands(&study)),
        ("slurm.sbatch", manifest.sbatch(&study)),
        ("ray_driver.py", Manifest::ray_driver(&study)),
        ("manifest.json", manifest.to_json()?),
    ] {
        staged.write(file, bytes.as_bytes())?;
    }
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    // Every file is complete: each is renamed into place, the manifest last.
    for file in PLAN_FILES {
        let dest = study.join(file);
        std::fs::rename(staged.path(file), &dest).with_context(|| format!("{}", dest.display()))?;
    }
    // Nothing is left to move: this flushes the directory and removes the staging one.
    staged.commit()?;
    println!(
        "planned {} runs ({} recipes × {} level sets × {} seeds) in {}",
        manifest.runs.len(),
        spec.recipes.len(),
        spec.levels.len(),
        spec.seeds.len(),
        study.display()
    );
    println!(
        "run here: groundscope study run {0}\non Slurm: sbatch {0}/slurm.sbatch\non Ray:   python {0}/ray_driver.py --address auto\nthen:     groundscope study collect {0}",
        study.display()
    );
    Ok(ExitStatus::Success)
}

/// A warning for each recipe whose `--init` parent is a relative path found from here but not
/// from the study directory, where the steps run (so the training would stop at once, naming
/// the missing checkpoint, perhaps hours after the plan). A parent found nowhere yet is
/// passed over: an earlier study may still be making it.
fn misplaced_parents(manifest: &Manifest, study: &Path) -> Vec<String> {
    // A parent is a run directory or a checkpoint's name, read as the loader reads it.
    let found = |p: &Path| p.is_dir() || groundscope::policy::checkpoint_paths(p).1.is_file();
    let mut warned: Vec<(&str, &str)> = Vec::new();
    let mut warnings = Vec::new();
    for run in &manifest.runs {
        let Some(init) = &run.train.init else {
            continue;
        };
        let parent = Path::new(&init.parent);
        if init.parent.starts_with("bundled:")
            || parent.is_absolute()
            || warned.contains(&(run.recipe.as_str(), init.parent.as_str()))
        {
            continue;
        }
        warned.push((&run.recipe, &init.parent));
        if !found(&study.join(parent)) && found(parent) {
            let here = std::path::absolute(parent).unwrap_or_else(|_| parent.to_path_buf());
            warnings.push(format!(
                "recipe {}: --init {}: a run's steps run in the study directory, {}, where there is no such checkpoint; from here it is {} (name it by that path, or by one relative to the study directory)",
                run.recipe,
                groundscope::study::shown(&init.parent),
                study.display(),
                here.to_string_lossy().escape_debug()
            ));
        }
    }
    warnings
}

/// Every run of the grid with its typed steps: each step written as its command's flags —
/// the recipe's and the level set's, then those the plan owns — and parsed and checked as
/// that command checks them before it runs ([`super::study_steps::typed_steps`]). A typo in a
/// recipe, an unknown level id or a value every run refuses (`--epochs 0`, `--alpha 1.5`,
/// `--jobs 0`) is refused here, naming the recipe, the level set and the flag, not hours later
/// on a cluster.
fn runs(spec: &StudySpec, spec_path: &Path) -> anyhow::Result<Vec<PlannedRun>> {
    let mut runs = Vec::new();
    for cell in spec.cells() {
        let (train, eval, faithfulness) = flags_of(spec, &cell);
        let steps = super::study_steps::typed_steps(&train, &eval, faithfulness.as_deref())
            .map_err(|why| {
                anyhow::anyhow!(
                    "{}: recipe {}, level set {}: {why}",
                    spec_path.display(),
                    cell.recipe,
                    cell.levels
                )
            })?;
        runs.push(PlannedRun::new(
            &cell.name,
            cell.recipe,
            cell.levels,
            cell.seed,
            steps,
        )?);
    }
    Ok(runs)
}

/// The flags of the steps of run `cell`: `train`'s, `eval`'s and, where the spec asks for one,
/// `faithfulness`'s, as the command lines of a study planned before its steps were typed held
/// them (so that such a plan reads back as the same typed steps).
fn flags_of(spec: &StudySpec, cell: &Cell<'_>) -> (Vec<String>, Vec<String>, Option<Vec<String>>) {
    let dir = format!("runs/{}", cell.name);
    let mut train = cell.flags.to_vec();
    train.extend(train_flags(cell.set));
    train.extend([
        "--seed".into(),
        cell.seed.to_string(),
        "--frames".into(),
        spec.frames.to_string(),
        "--out".into(),
        dir.clone(),
        "--quiet".into(),
    ]);
    let step = |flags: &[String], out: &str| {
        let mut a = vec!["--checkpoint".to_owned(), dir.clone()];
        a.extend(eval_flags(cell.set));
        a.extend(flags.iter().cloned());
        a.extend(["--out".into(), format!("{dir}/{out}"), "--quiet".into()]);
        a
    };
    let eval = step(&spec.eval, "eval");
    let faithfulness = spec
        .faithfulness
        .as_deref()
        .map(|f| step(f, "faithfulness"));
    (train, eval, faithfulness)
}

/// The training's flags for level set `set`: none for the paper's level, `--level ID` for a
/// registered id, or the set's own.
fn train_flags(set: &LevelSet) -> Vec<String> {
    match set {
        LevelSet::Named(n) if n == PAPER => Vec::new(),
        LevelSet::Named(id) => vec!["--level".into(), id.clone()],
        LevelSet::Flags { train, .. } => train.clone(),
    }
}

/// The evaluation's flags for level set `set`: its own, else the training's levels (`--level
/// ID` or `--levels A,B:2`, the weights being training's alone), else the paper's 8×8 room with
/// 4 objects.
fn eval_flags(set: &LevelSet) -> Vec<String> {
    if let LevelSet::Flags { eval: Some(e), .. } = set {
        return e.clone();
    }
    let train = train_flags(set);
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

/// Refuses a recipe, a level set or a step that gives a flag the plan sets for each run,
/// naming it (`recipe ppo gives --out`).
fn check_owned(spec: &StudySpec, file: &Path) -> anyhow::Result<()> {
    let owned = |flags: &[String], owned: &[&str], what: &str| {
        for f in flags {
            let flag = f.split('=').next().unwrap_or(f);
            if owned.contains(&flag) {
                anyhow::bail!(
                    "{}: {what} gives {flag}, which the plan sets for each run",
                    file.display()
                );
            }
        }
        Ok(())
    };
    for (name, flags) in &spec.recipes {
        owned(flags, &OWNED_TRAIN, &format!("recipe {name}"))?;
    }
    for (name, set) in &spec.levels {
        owned(
            &train_flags(set),
            &OWNED_TRAIN,
            &format!("level set {name}"),
        )?;
        owned(
            &eval_flags(set),
            &OWNED_STEP,
            &format!("level set {name}'s eval"),
        )?;
    }
    owned(&spec.eval, &OWNED_STEP, "eval")?;
    if let Some(f) = &spec.faithfulness {
        owned(f, &OWNED_STEP, "faithfulness")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPEC: &str = include_str!("../study/test_spec.toml");

    fn planned(text: &str) -> anyhow::Result<Manifest> {
        let path = Path::new("study.toml");
        let spec = StudySpec::parse(text, path)?;
        check_owned(&spec, path)?;
        Ok(Manifest::new("s", "groundscope", runs(&spec, path)?))
    }

    #[test]
    fn a_spec_plans_typed_steps_from_its_flags() {
        let m = planned(SPEC).unwrap();
        assert_eq!(m.runs.len(), 8);
        let r = m.run("ent-mix-s2").unwrap();
        assert_eq!(r.threads, 2);
        assert_eq!((r.train.seed, r.train.frames), (2, 1000));
        assert_eq!(r.train.ppo.entropy_coef, 0.001);
        assert_eq!(r.train.levels.entries().len(), 2);
        // eval reads the levels without training's weights, then the spec's flags.
        assert_eq!(
            r.eval.sweep.levels,
            ["BabyAI-GoToLocal-v0", "BabyAI-PickupLoc-v0"]
        );
        assert_eq!(r.eval.sweep.episodes, 10);
        let paper = m.run("ppo-paper-s1").unwrap();
        assert_eq!(paper.eval.sweep.sizes, [8]);
        assert_eq!(paper.eval.sweep.objects, [4]);
        assert!(paper.eval.sweep.levels.is_empty() && paper.train.init.is_none());
        // The same spec plans the same manifest; a changed run is refused by name, an added one
        // is not.
        assert_eq!(planned(SPEC).unwrap(), m);
        let more = planned(&SPEC.replace("[1, 2]", "[1, 2, 3]")).unwrap();
        check_replan(&m, &more).unwrap();
        let changed = planned(&SPEC.replace("\"10\"", "\"20\"")).unwrap();
        let e = check_replan(&m, &changed).unwrap_err().to_string();
        assert!(
            e.contains("changes run ent-mix-s1") && e.contains("eval"),
            "{e}"
        );
    }

    #[test]
    fn a_warm_start_keeps_its_parent_and_the_network_flags_given() {
        let text = SPEC.replace(
            "ppo = [\"--model\", \"attention\"]",
            "ppo = [\"--model\", \"attention\", \"--init\", \"bundled:attention\", \"--hidden\", \"128\"]",
        );
        let m = planned(&text).unwrap();
        let init = m.run("ppo-paper-s1").unwrap().train.init.clone().unwrap();
        assert_eq!(init.parent, "bundled:attention");
        assert_eq!(init.fixed, ["hidden"]);
    }

    #[test]
    fn a_relative_parent_found_only_from_here_is_warned_of_once_per_recipe() {
        // The tests run in the package's root, where assets/minigrid.json is.
        let with = |parent: &str| {
            SPEC.replace(
                "ppo = [\"--model\", \"attention\"]",
                &format!("ppo = [\"--model\", \"attention\", \"--init\", \"{parent}\"]"),
            )
        };
        let study = tempfile::tempdir().unwrap();
        let warnings = misplaced_parents(&planned(&with("assets/minigrid")).unwrap(), study.path());
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(
            warnings[0].starts_with("recipe ppo: --init \"assets/minigrid\""),
            "{}",
            warnings[0]
        );
        assert!(
            warnings[0].contains(
                &std::path::absolute("assets/minigrid")
                    .unwrap()
                    .display()
                    .to_string()
            )
        );
        // Found from the study directory, found nowhere yet, absolute or bundled: nothing.
        std::fs::create_dir_all(study.path().join("assets/minigrid")).unwrap();
        let absolute = std::path::absolute("assets/minigrid").unwrap();
        for parent in [
            "assets/minigrid",
            "runs/not-yet",
            absolute.to_str().unwrap(),
            "bundled:attention",
        ] {
            let m = planned(&with(parent)).unwrap();
            assert!(misplaced_parents(&m, study.path()).is_empty(), "{parent}");
        }
    }

    #[test]
    fn flags_the_plan_owns_or_no_command_takes_are_refused_naming_the_recipe() {
        for (text, says) in [
            (
                SPEC.replace("\"--model\", \"attention\"]\nent", "\"--out\", \"x\"]\nent"),
                "recipe ppo gives --out",
            ),
            (
                SPEC.replace("eval = [", "eval = [\"--checkpoint\", \"x\", "),
                "eval gives --checkpoint",
            ),
            (
                SPEC.replace("\"--threads\", \"2\"", "\"--thread\", \"2\""),
                "recipe ent, level set mix: train: ",
            ),
            (
                SPEC.replace("\"--episodes\", \"10\"", "\"--episodes\", \"0\""),
                ": eval: ",
            ),
        ] {
            let e = format!("{:#}", planned(&text).unwrap_err());
            assert!(e.contains(says) && e.contains("study.toml"), "{says}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
