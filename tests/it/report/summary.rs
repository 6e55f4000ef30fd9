//! What `report.md` says it found (issue #83): it opens with a summary of at most eight lines
//! whose figures are its tables'; every figure the command writes is linked under the table it
//! shows (a sweep over BabyAI levels gains its grounding figure); every grounding value carries
//! its count and none under the minimum is flagged; the worst episodes are failures or under
//! the `acc_cmb` threshold, never perfect.

use std::path::Path;

use crate::common::{gs, stderr};
use groundscope::metrics::report::{
    FIG_GROUNDING_LEVELS, LEVELS_SUCCESS, LOW_ACC_CMB, SUMMARY_MAX_LINES,
};
use groundscope::metrics::words::MIN_EVALUATED_STEPS;

fn eval(out: &Path, args: &[&str]) -> String {
    let mut a = vec!["eval"];
    a.extend(args);
    a.extend(["--quiet", "--out", out.to_str().unwrap()]);
    let o = gs(&a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::read_to_string(out.join("report.md")).unwrap()
}

/// The section of `md` under the heading that starts with `heading`, up to the next `## `.
fn section<'a>(md: &'a str, heading: &str) -> &'a str {
    let start = md
        .find(&format!("\n## {heading}"))
        .unwrap_or_else(|| panic!("no section {heading}:\n{md}"));
    let body = &md[start + 1..];
    let end = body[3..].find("\n## ").map_or(body.len(), |i| i + 3);
    &body[..end]
}

/// The PNG files of `dir`, sorted.
fn figures(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| Path::new(n).extension().is_some_and(|e| e == "png"))
        .collect();
    names.sort();
    names
}

/// The summary opens the report, holds at most the documented lines, and quotes the tables.
fn check_summary(md: &str) {
    assert!(
        md.starts_with("# groundscope evaluation\n\n## Summary\n\n"),
        "{md}"
    );
    let summary = section(md, "Summary");
    let lines: Vec<&str> = summary
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .collect();
    assert!(
        !lines.is_empty() && lines.len() <= SUMMARY_MAX_LINES,
        "{summary}"
    );
    assert!(lines.iter().all(|l| l.starts_with("- **")), "{summary}");
    assert!(summary.contains("**Success**"), "{summary}");
    assert!(
        summary.contains("**Main failure classes**") || summary.contains("**Failures**: none"),
        "{summary}"
    );
}

/// Every value of a flagged word holds at least the minimum count.
fn check_flags(md: &str) {
    let rows = md.lines().filter(|l| l.starts_with('|'));
    for cell in rows.flat_map(|l| l.split('|')).filter(|c| c.contains('⚠')) {
        let steps: u64 = cell
            .split('(')
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("a flag without its count: {cell}"));
        assert!(
            steps >= MIN_EVALUATED_STEPS,
            "flagged on {steps} steps: {cell}"
        );
    }
}

/// No episode is listed for its `acc_cmb` at or above the threshold.
fn check_worst(out: &Path) {
    let listed: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(out.join("failures.json")).unwrap()).unwrap();
    for f in &listed {
        if f["kind"] == "low_acc_cmb" {
            let a = f["acc_cmb"].as_f64().unwrap();
            assert!(a < LOW_ACC_CMB, "{f}");
        } else {
            assert_eq!(f["kind"], "failed", "{f}");
        }
    }
}

#[test]
fn a_level_sweep_opens_with_its_summary_and_links_every_figure_under_its_table() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("levels");
    let md = eval(
        &out,
        &[
            "--checkpoint",
            "bundled:babyai",
            "--levels",
            "BabyAI-GoToDoor-v0,BabyAI-GoToLocal-v0",
            "--seeds",
            "1",
            "--episodes",
            "12",
        ],
    );
    check_summary(&md);
    // Both levels are named; what grounds is said beside its chance.
    let summary = section(&md, "Summary");
    assert!(summary.contains("(chance "), "{summary}");
    // Each figure is linked in the section of the table it shows, and every PNG is linked.
    let figs = figures(&out);
    assert!(figs.contains(&FIG_GROUNDING_LEVELS.to_owned()), "{figs:?}");
    for (fig, heading) in [
        (LEVELS_SUCCESS, "Per level"),
        (FIG_GROUNDING_LEVELS, "Pointing game per level"),
        ("fig_exploration.png", "Exploration of the failed episodes"),
        (
            "fig_exploration_maps.png",
            "The maps while no target is in view",
        ),
    ] {
        assert!(
            section(&md, heading).contains(&format!("]({fig})")),
            "{fig} not under {heading}:\n{md}"
        );
    }
    for fig in &figs {
        assert!(
            md.contains(&format!("]({fig})")),
            "{fig} is not linked:\n{md}"
        );
    }
    // The per-level grounding table gives each pointing game with its chance and its count.
    let table = section(&md, "Pointing game per level");
    assert!(
        table.contains("| bundled:babyai | BabyAI-GoToLocal-v0 | ")
            && table.contains(" (chance ")
            && table.contains(" steps) |"),
        "{table}"
    );
    // Counts beside every word's value; no flag on a count under the minimum.
    let words = section(&md, "Each word's map on its objects");
    assert!(
        words.contains(" steps)") || words.contains(" step)"),
        "{words}"
    );
    check_flags(&md);
    check_worst(&out);
    // The figure is drawn: a picture with a row per level.
    let (w, h) = image::image_dimensions(out.join(FIG_GROUNDING_LEVELS)).unwrap();
    assert!(w >= 900 && h > 200, "{w}×{h}");
}

#[test]
fn the_papers_sweep_links_figs_6_to_8_under_their_tables() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("paper");
    let md = eval(
        &out,
        &[
            "--sizes",
            "8",
            "--objects",
            "4",
            "--seeds",
            "1",
            "--episodes",
            "10",
        ],
    );
    check_summary(&md);
    for (fig, heading) in [
        ("fig6_reward.png", "Task performance"),
        ("fig6_success.png", "Task performance"),
        ("fig7_object_accuracy.png", "Object-word maps"),
        ("fig8_color_accuracy.png", "Colour-word maps"),
        ("fig_exploration.png", "Exploration of the failed episodes"),
    ] {
        assert!(
            section(&md, heading).contains(&format!("]({fig})")),
            "{fig} not under {heading}:\n{md}"
        );
    }
    for fig in figures(&out) {
        assert!(
            md.contains(&format!("]({fig})")),
            "{fig} is not linked:\n{md}"
        );
    }
    assert!(!out.join(FIG_GROUNDING_LEVELS).exists());
    // The worst episodes say how they were chosen, and list no perfect episode.
    assert!(
        section(&md, "Worst episodes").contains(&format!("under {LOW_ACC_CMB}")),
        "{md}"
    );
    check_flags(&md);
    check_worst(&out);
}
