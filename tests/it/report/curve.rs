//! `groundscope curve` on the flat logs `experiments/runs/` keeps: seed bands and the tracked
//! grounding. (Split from `train::cli`.)

use crate::common::{assert_bad_input, gs, stderr, stdout};

use std::path::Path;

#[test]
fn curve_reads_bundled_flat_logs_as_seed_bands() {
    // Two seeds of one recipe as `experiments/runs/` keeps them: NAME_log.csv and
    // NAME_eval_log.csv side by side.
    let dir = tempfile::tempdir().unwrap();
    let study = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/recipe_study");
    let mut files = Vec::new();
    for seed in [1, 2] {
        for (src, dst) in [("log.csv", "log.csv"), ("eval_log.csv", "eval_log.csv")] {
            let to = dir.path().join(format!("attention_seed{seed}_{dst}"));
            std::fs::copy(study.join(format!("recurrence16-s{seed}/{src}")), &to).unwrap();
            files.push(to.to_str().unwrap().to_owned());
        }
    }
    let out = dir.path().join("fig.png");
    let mut args = vec!["curve"];
    args.extend(files.iter().map(String::as_str));
    args.extend(["--out", out.to_str().unwrap()]);
    let o = gs(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    // One band of two seeds, and the grounding figure from the eval logs beside them.
    assert!(stdout(&o).contains("fig_grounding.png"), "{}", stdout(&o));
    for f in ["fig.png", "fig_grounding.png"] {
        assert!(image::open(dir.path().join(f)).is_ok(), "{f}");
    }
    // The same runs with `acc` instead of `acc_ng`: other columns, so another picture.
    let acc_ng = std::fs::read(dir.path().join("fig_grounding.png")).unwrap();
    let acc_out = dir.path().join("acc.png");
    let mut acc_args = vec!["curve", "--accuracy", "acc"];
    acc_args.extend(files.iter().map(String::as_str));
    acc_args.extend(["--out", acc_out.to_str().unwrap()]);
    let o = gs(&acc_args);
    assert!(o.status.success(), "{}", stderr(&o));
    let acc = std::fs::read(dir.path().join("acc_grounding.png")).unwrap();
    assert!(image::load_from_memory(&acc).is_ok());
    assert_ne!(acc, acc_ng);
    // Only evaluation logs: nothing to draw.
    let only_evals = gs(&[
        "curve",
        &files[1],
        &files[3],
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_bad_input(&only_evals, "no training log");
    // A bad tracked evaluation is found before anything is drawn: no figure at all.
    let fresh = dir.path().join("fresh.png");
    std::fs::write(&files[3], "frames,greedy_success\n100,0.5\n").unwrap();
    let bad_eval = gs(&[
        "curve",
        &files[0],
        &files[2],
        "--out",
        fresh.to_str().unwrap(),
    ]);
    assert_bad_input(&bad_eval, "object_acc_ng");
    assert!(!fresh.exists(), "no reward figure either");
}
