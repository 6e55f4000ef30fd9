//! `groundscope eval` writes the exploration coverage (docs/exploration.md): `exploration.csv`
//! with the documented header, one line per cell and outcome, fractions and entropies in
//! [0, 1]; the `report.json` `exploration` objects; the `report.md` tables; the figures.

use crate::common::{gs, stderr};
use groundscope::metrics::exploration::{
    EXPLORATION_CSV_HEADER, FIG_EXPLORATION, FIG_EXPLORATION_MAPS,
};

/// The columns whose values are shares or normalised entropies.
fn in_unit_interval(column: &str) -> bool {
    column.contains("_frac_") || column.contains("entropy") || column.starts_with("m_max")
}

#[test]
fn eval_writes_exploration_csv_with_the_documented_header_and_bounded_values() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let eval = |checkpoints: &[&str]| {
        let mut a = vec!["eval"];
        for c in checkpoints {
            a.extend(["--checkpoint", c]);
        }
        a.extend([
            "--sizes",
            "8,14",
            "--objects",
            "8",
            "--seeds",
            "2",
            "--episodes",
            "4",
            "--quiet",
            "--jobs",
            "1",
            "--out",
        ]);
        a.push(out.to_str().unwrap());
        let o = gs(&a);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    };
    eval(&["bundled:attention", "bundled:baseline"]);

    // The header is the documented one, word for word.
    let doc = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/exploration.md"),
    )
    .unwrap();
    assert!(
        doc.contains(EXPLORATION_CSV_HEADER),
        "docs/exploration.md quotes the header"
    );
    let text = std::fs::read_to_string(out.join("exploration.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(EXPLORATION_CSV_HEADER));
    let header: Vec<&str> = EXPLORATION_CSV_HEADER.split(',').collect();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // 2 checkpoints × 2 sizes × 1 object count × 3 outcomes.
    assert_eq!(rows.len(), 12);
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let mut checked = 0;
    let mut failures_measured = 0;
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), header.len(), "row {i}: {r:?}");
        assert_eq!(r[col("outcome")], ["all", "success", "failure"][i % 3]);
        for (h, v) in header.iter().zip(r) {
            if in_unit_interval(h) && !v.is_empty() {
                let x: f64 = v.parse().unwrap();
                if h.ends_with("_mean") {
                    assert!((0.0..=1.0).contains(&x), "{h} = {x} in row {i}");
                } else {
                    assert!((0.0..=0.5).contains(&x), "{h} (a std) = {x} in row {i}");
                }
                checked += 1;
            }
        }
        let baseline = r[col("variant")] == "baseline";
        let has_maps = !r[col("m_entropy_hidden_mean")].is_empty();
        assert!(!(baseline && has_maps), "a baseline has no maps (row {i})");
        if r[col("outcome")] == "failure" && !r[col("seen_frac_mean")].is_empty() {
            failures_measured += 1;
        }
    }
    assert!(checked > 100, "{checked} bounded values checked");
    assert!(
        failures_measured > 0,
        "S14N8 has failed episodes to measure"
    );
    // Episodes split into successes and failures.
    for cell in rows.chunks(3) {
        let n = |r: &Vec<&str>| r[col("episodes")].parse::<u64>().unwrap();
        assert_eq!(n(&cell[0]), 8);
        assert_eq!(n(&cell[1]) + n(&cell[2]), n(&cell[0]));
    }

    // report.json: every cell gains an exploration object, the schema stays version 1.
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(v["schema_version"], 1);
    for cell in v["cells"].as_array().unwrap() {
        let x = &cell["exploration"];
        for outcome in ["all", "success", "failure"] {
            assert!(x[outcome]["episodes"].is_u64(), "{outcome}");
        }
        assert!(x["all"]["seen_frac"]["mean"].is_f64());
        assert_eq!(
            x["all"]["maps"].is_null(),
            cell["variant"] == "baseline",
            "maps for attention cells only"
        );
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("## Exploration of the failed episodes"));
    assert!(md.contains("## The maps while no target is in view"));
    assert!(out.join(FIG_EXPLORATION).exists());
    assert!(out.join(FIG_EXPLORATION_MAPS).exists());

    // A baseline-only report in the same directory keeps no maps figure from the last one.
    eval(&["bundled:baseline"]);
    assert!(out.join(FIG_EXPLORATION).exists());
    assert!(
        !out.join(FIG_EXPLORATION_MAPS).exists(),
        "stale maps figure removed"
    );
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(!md.contains("## The maps while no target is in view"));
}
