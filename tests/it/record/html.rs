//! The HTML episode page (`replay --html`) and report (`eval --html`) as files: written whole,
//! self-contained, small on a long episode, its numbers the trace's, refused flags leaving
//! nothing. What a browser makes of them is in `browser`.

use std::path::Path;

use crate::common::{FAILING_SWEEP, assert_bad_input, entries, gs, stderr};

/// The values of every `attr="…"` in `html`.
pub fn attr_values<'a>(html: &'a str, attr: &str) -> Vec<&'a str> {
    let key = format!("{attr}=\"");
    html.match_indices(&key)
        .filter_map(|(i, _)| {
            let rest = &html[i + key.len()..];
            rest.find('"').map(|end| &rest[..end])
        })
        .collect()
}

/// Fails unless `html` reaches for nothing outside itself: no `http://` or `https://` at
/// all, no protocol-relative source, every `src` a `data:` URI.
pub fn assert_self_contained(html: &str, what: &str) {
    for remote in ["http://", "https://", "src=\"//", "href=\"//"] {
        assert!(!html.contains(remote), "{what} holds {remote:?}");
    }
    for src in attr_values(html, "src") {
        assert!(src.starts_with("data:"), "{what}: src=\"{src:.60}…\"");
    }
}

/// The data an episode page draws from (its `gs-data` script).
pub fn page_data(html: &str) -> serde_json::Value {
    let open = "<script id=\"gs-data\" type=\"application/json\">";
    let start = html.find(open).expect("the page's data") + open.len();
    let end = start + html[start..].find("</script>").expect("its end");
    serde_json::from_str(&html[start..end]).expect("the data is JSON")
}

/// `replay --html` with `args`, into `dir`; fails unless it exits 0.
fn replay_html(dir: &Path, name: &str, args: &[&str]) -> String {
    let page = dir.join(name);
    let mut all = vec!["replay", "--html", page.to_str().unwrap()];
    all.extend_from_slice(args);
    let o = gs(&all);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::read_to_string(&page).unwrap()
}

#[test]
fn a_replay_page_is_one_self_contained_file_holding_the_traces_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let trace = tmp.path().join("t.json");
    let html = replay_html(
        tmp.path(),
        "ep.html",
        &["--seed", "3", "--trace", trace.to_str().unwrap()],
    );
    // Nothing beside it: no temporary file left, the page alone with the trace.
    assert_eq!(entries(tmp.path()), ["ep.html", "t.json"]);
    assert!(html.starts_with("<!doctype html>"), "{html:.80}");
    assert!(html.trim_end().ends_with("</html>"));
    assert_self_contained(&html, "ep.html");
    let data = page_data(&html);
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    let panels = data["panels"].as_array().unwrap();
    assert_eq!(panels.len(), 1);
    let p = &panels[0];
    let (steps, trace_steps) = (
        p["steps"].as_array().unwrap(),
        t["steps"].as_array().unwrap(),
    );
    assert_eq!(steps.len(), trace_steps.len());
    assert_eq!(p["mission"], t["mission"]);
    assert_eq!(
        p["actions"].as_array().unwrap().len(),
        7,
        "the paper's level: 7"
    );
    for (s, ts) in steps.iter().zip(trace_steps) {
        // The probabilities and weights the page shows are the trace's, to the bit.
        assert_eq!(s["p"], ts["probs"], "step {}", ts["t"]);
        assert_eq!(s["a"], ts["action"]);
        let words = ts["attention"]["words"].as_array().unwrap();
        let w: Vec<&serde_json::Value> = words.iter().map(|w| &w["weight"]).collect();
        assert_eq!(
            s["att"]["w"].as_array().unwrap().iter().collect::<Vec<_>>(),
            w
        );
        // One shared scale a step: no map value above it.
        let q = s["att"]["m"].as_array().unwrap();
        assert_eq!(q.len(), 49);
        assert!(q.iter().all(|v| v.as_u64().unwrap() <= 1000));
        assert!(s["att"]["s"].as_f64().unwrap() > 0.0);
    }
    // The atlas is a PNG that decodes.
    let png = data["atlas"]["png"].as_str().unwrap();
    let bytes = base64_decode(png.strip_prefix("data:image/png;base64,").unwrap());
    let img = image::load_from_memory(&bytes).unwrap();
    assert!(img.width() > 0 && img.height() > 0);
}

/// `s` decoded from standard base64.
pub fn base64_decode(s: &str) -> Vec<u8> {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD.decode(s).unwrap()
}

/// BossLevel seed 3 runs bundled:babyai to its 1,728-step limit on a 22×22 world with a long
/// mission: the page stays well under 5 MB for 400 steps.
#[test]
fn a_long_episodes_page_stays_small() {
    let tmp = tempfile::tempdir().unwrap();
    let html = replay_html(
        tmp.path(),
        "long.html",
        &[
            "--checkpoint",
            "bundled:babyai",
            "--level",
            "BabyAI-BossLevel-v0",
            "--seed",
            "3",
        ],
    );
    let steps = page_data(&html)["panels"][0]["steps"]
        .as_array()
        .unwrap()
        .len();
    assert!(steps >= 400, "{steps} steps");
    let per_400 = html.len() * 400 / steps;
    assert!(
        per_400 < 4_000_000,
        "{} bytes for {steps} steps: {per_400} bytes per 400 steps",
        html.len()
    );
    assert_self_contained(&html, "long.html");
}

#[test]
fn bad_html_flags_are_refused_in_one_line_and_leave_no_file() {
    let tmp = tempfile::tempdir().unwrap();
    let page = tmp.path().join("ep.html");
    let p = page.to_str().unwrap();
    let wrong = tmp.path().join("ep.htm");
    for (args, what) in [
        (vec!["--html", wrong.to_str().unwrap()], "must end in .html"),
        (
            vec!["--html", p, "--episodes", "2"],
            "--html writes one episode",
        ),
        (
            vec!["--compare", "bundled:baseline"],
            "--compare needs --html",
        ),
        (vec!["--html", p, "--trace", p], "name the same file"),
        (
            vec!["--html", p, "--compare", "no/such/checkpoint"],
            "no/such/checkpoint",
        ),
    ] {
        let mut all = vec!["replay", "--seed", "1"];
        all.extend_from_slice(&args);
        assert_bad_input(&gs(&all), what);
        assert!(entries(tmp.path()).is_empty(), "{args:?} left a file");
    }
    // A directory that does not exist: the error names the page, and nothing is made.
    let missing = tmp.path().join("missing/ep.html");
    let o = gs(&["replay", "--seed", "1", "--html", missing.to_str().unwrap()]);
    assert_bad_input(&o, "missing/ep.html");
    assert!(entries(tmp.path()).is_empty());
}

#[test]
fn a_compare_page_holds_both_checkpoints_on_one_episode() {
    let tmp = tempfile::tempdir().unwrap();
    let html = replay_html(
        tmp.path(),
        "both.html",
        &["--seed", "5", "--compare", "bundled:baseline"],
    );
    let data = page_data(&html);
    let panels = data["panels"].as_array().unwrap();
    assert_eq!(panels.len(), 2);
    for key in ["level", "seed", "mission"] {
        assert_eq!(panels[0][key], panels[1][key], "{key}");
    }
    assert!(panels[0]["title"].as_str().unwrap().contains("attention"));
    assert!(panels[1]["title"].as_str().unwrap().contains("baseline"));
    // The baseline has no maps.
    assert!(panels[1]["words"].as_array().unwrap().is_empty());
    assert!(panels[1]["steps"][0].get("att").is_none());
    assert_self_contained(&html, "both.html");
}

/// `eval --html`: report.html beside report.md with its figures inline, and each worst
/// episode's row linking its own page, which exists; a later run without `--html` removes
/// both, as it removes figures it no longer draws.
#[test]
fn eval_html_writes_the_report_and_a_page_per_worst_episode() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("r");
    let o_str = out.to_str().unwrap();
    let mut args = vec![
        "eval",
        "--checkpoint",
        "bundled:attention",
        "--out",
        o_str,
        "--top-k",
        "2",
        "--html",
        "--quiet",
    ];
    args.extend(FAILING_SWEEP);
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_self_contained(&html, "report.html");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    // Every figure report.md shows is inline, and decodes.
    let figures = md.matches("![").count();
    let images = attr_values(&html, "src");
    assert!(
        figures > 0 && images.len() == figures,
        "{figures} figures, {} images",
        images.len()
    );
    for src in images {
        let b64 = src.strip_prefix("data:image/png;base64,").expect("a PNG");
        let img = image::load_from_memory(&base64_decode(b64)).unwrap();
        assert!(
            img.width() > 50,
            "a figure {}×{}",
            img.width(),
            img.height()
        );
    }
    // Each worst episode links its page, and the page is there.
    let links: Vec<&str> = attr_values(&html, "href")
        .into_iter()
        .filter(|h| h.starts_with("episodes/"))
        .collect();
    assert!(!links.is_empty(), "no episode linked");
    let mut pages = std::collections::BTreeSet::new();
    for link in &links {
        let file = link.split('#').next().unwrap();
        let page = out.join(file);
        assert!(page.is_file(), "{link} does not exist");
        assert!(md.contains(link), "report.md does not link {link}");
        pages.insert(file.trim_start_matches("episodes/").to_owned());
    }
    assert_eq!(
        entries(&out.join("episodes")),
        pages.into_iter().collect::<Vec<_>>(),
        "one page per listed episode, nothing else"
    );
    let first = std::fs::read_to_string(out.join(links[0].split('#').next().unwrap())).unwrap();
    assert_self_contained(&first, links[0]);
    assert!(!entries(&out).iter().any(|n| n.starts_with(".groundscope")));
    // Again without --html: neither the report's HTML nor its pages stay.
    let args: Vec<&str> = args.into_iter().filter(|a| *a != "--html").collect();
    let o = gs(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!out.join("report.html").exists());
    assert!(!out.join("episodes").exists());
    assert!(
        !std::fs::read_to_string(out.join("report.md"))
            .unwrap()
            .contains("episodes/")
    );
}
