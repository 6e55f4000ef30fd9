//! Every CSV file keeps its columns whatever a checkpoint is called: a name holding a comma
//! and a quote is one quoted field in `eval`'s CSVs, `validate`'s and the faithfulness steps.

use crate::common::{gs, stderr};
use groundscope::table::read;

#[test]
fn a_checkpoint_name_with_a_comma_and_a_quote_stays_one_field() {
    let dir = tempfile::tempdir().unwrap();
    let name = dir.path().join("run,1 \"b\"");
    let name = name.to_str().unwrap();
    let o = gs(&["init", "--model", "attention", "--out", name]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (eval, faith, valid) = (
        dir.path().join("eval"),
        dir.path().join("faith"),
        dir.path().join("v.csv"),
    );
    let runs: [&[&str]; 3] = [
        &[
            "eval",
            "--sizes",
            "8",
            "--objects",
            "4",
            "--seeds",
            "1",
            "--episodes",
            "3",
        ],
        &["faithfulness", "--seeds", "1", "--episodes", "2"],
        &["validate", "--episodes", "3"],
    ];
    for (args, out) in runs.iter().zip([&eval, &faith, &valid]) {
        let mut all = args.to_vec();
        if args[0] == "validate" {
            all.extend([name, "--out", out.to_str().unwrap()]);
        } else {
            all.extend([
                "--checkpoint",
                name,
                "--quiet",
                "--out",
                out.to_str().unwrap(),
            ]);
        }
        let o = gs(&all);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    }
    let files = [
        eval.join("performance.csv"),
        eval.join("accuracy.csv"),
        eval.join("words.csv"),
        eval.join("around.csv"),
        eval.join("exploration.csv"),
        faith.join("faithfulness_steps.csv"),
        valid,
    ];
    for f in files {
        let (header, rows) = read(&std::fs::read_to_string(&f).unwrap()).unwrap();
        assert_eq!(header[0], "checkpoint", "{}", f.display());
        assert!(!rows.is_empty(), "{}", f.display());
        for r in rows {
            assert_eq!(r.len(), header.len(), "{}: {r:?}", f.display());
            // The faithfulness steps name the checkpoint and its level.
            assert!(
                r[0] == name || r[0].starts_with(&format!("{name} S8N4")),
                "{}: {r:?}",
                f.display()
            );
        }
    }
}
