//! The layout of a `.rrd` read back from the file: every bar chart's label sits right above
//! its own bar and inside the chart (Rerun 0.36 draws a 2-D label centred below its anchor),
//! a chart with more rows than fit at a readable size scrolls instead of overprinting, and a
//! long mission's function words fold out of view as the debugger folds them.

use crate::common::rrd::{Decoded, decode, rows};
use groundscope::env::level::{LevelConfig, LevelId};
use groundscope::env::roles::roles_of;
use groundscope::episode::{ActionMode, EpisodeSpec, EpisodeTrace, run_episode};
use groundscope::policy::bundled;
use groundscope::record::fold::{FOLD_ABOVE_WORDS, folded_words};
use groundscope::record::{RerunTargets, record_rerun};

const ACTIONS: [&str; 7] = [
    "left", "right", "forward", "pickup", "drop", "toggle", "done",
];

/// `checkpoint`'s greedy episode on `level` (`None`: its own) and `seed`.
fn episode(checkpoint: &str, level: Option<&str>, seed: u64) -> EpisodeTrace {
    let ckpt = bundled::load(checkpoint).unwrap();
    let level = level.map_or(ckpt.meta.level, |id| {
        LevelConfig::babyai(LevelId::parse(id).unwrap(), false)
    });
    let spec = EpisodeSpec {
        level,
        seed,
        mission: None,
        mode: ActionMode::Greedy,
    };
    run_episode(&ckpt, checkpoint, &spec).unwrap()
}

fn recorded(eps: &[EpisodeTrace]) -> Decoded {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("layout.rrd");
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    record_rerun(eps, &targets, 0.5, None).unwrap();
    decode(&path)
}

/// The number a bar's label gives after `key` (`"forward 0.697"`: the last word).
fn value_after(label: &str, key: &str) -> f32 {
    let tail = if key.is_empty() {
        label.rsplit(' ').next().unwrap()
    } else {
        let at = label
            .find(key)
            .unwrap_or_else(|| panic!("{key:?} in {label:?}"));
        label[at + key.len()..].split(' ').next().unwrap()
    };
    tail.parse()
        .unwrap_or_else(|_| panic!("a number in {label:?}"))
}

/// Checks chart `path` at every step: row i's label names `names[k][i]` and the value bar i
/// shows (to the label's rounding), is anchored above bar i and below bar i − 1 (so that the
/// text Rerun draws below the anchor lies between them, nearer its own bar), centred on the
/// bar, and the last bar ends inside the chart's frame.
fn check_chart(d: &Decoded, path: &str, full: f32, key: &str, names: &[Vec<String>]) {
    let labels = &d.labels[path];
    let anchors = &d.points[path];
    let bars = &d.strips[&format!("{path}/bars")];
    let tracks = &d.boxes[&format!("{path}/tracks")];
    let frames = &d.boxes[&format!("{path}/frame")];
    assert_eq!(labels.len(), names.len(), "{path}: a row per step");
    let scale = 10.0 / full;
    for (k, want) in names.iter().enumerate() {
        let (labels, anchors, bars, tracks) = (&labels[k], &anchors[k], &bars[k], &tracks[k]);
        assert_eq!(
            [labels.len(), anchors.len(), bars.len(), tracks.len()],
            [want.len(); 4],
            "{path} step {k}"
        );
        let mut prev_bottom = 0.0;
        for i in 0..want.len() {
            let (label, [ax, ay]) = (&labels[i], anchors[i]);
            assert!(
                label.starts_with(&want[i]),
                "{path} step {k} row {i}: {label:?}"
            );
            // A strip stops a radius short of each end: the bar covers [0, end + r].
            let [[x0, y], [x1, _]] = [bars[i][0], bars[i][1]];
            let r = x0;
            let shown = x1 + r;
            let value = value_after(label, key);
            let expect = (value * scale).clamp(2.0 * r, 10.0);
            assert!(
                (shown - expect).abs() <= 0.005 * scale + 1e-3,
                "{path} step {k}: bar {i} is {shown} long, its label {label:?} says {expect}"
            );
            let (top, bottom) = (y - r, y + r);
            assert!(
                prev_bottom <= ay && ay < top,
                "{path} step {k}: label {i} at y {ay} is not between bar {} (ends {prev_bottom}) and its own bar (from {top})",
                i.saturating_sub(1)
            );
            assert!(
                top - ay >= 2.0 * (bottom - top),
                "{path} step {k}: label {i} has too little room above its bar"
            );
            let [tx0, ty0, tx1, ty1] = tracks[i];
            assert!((ty0 - top).abs() < 1e-4 && (ty1 - bottom).abs() < 1e-4);
            assert!(
                (ax - f32::midpoint(tx0, tx1)).abs() < 1e-4,
                "centred on its bar"
            );
            prev_bottom = bottom;
        }
        let frame = frames[k.min(frames.len() - 1)][0];
        assert!(
            prev_bottom <= frame[3],
            "{path} step {k}: the last bar ends at {prev_bottom}, outside the frame {frame:?}"
        );
    }
}

/// Row i's names at every step of `eps`: `f(step)`.
fn names_of(
    eps: &[EpisodeTrace],
    f: impl Fn(&groundscope::episode::StepRecord) -> Vec<String>,
) -> Vec<Vec<String>> {
    eps.iter().flat_map(|e| e.steps.iter().map(&f)).collect()
}

#[test]
fn every_bar_sits_under_its_own_label_inside_its_chart() {
    let eps = vec![
        episode("bundled:attention", None, 3),
        episode("bundled:attention", None, 4),
    ];
    let d = recorded(&eps);
    let actions = names_of(&eps, |_| ACTIONS.map(|a| format!("{a} ")).to_vec());
    check_chart(&d, "/policy/probs", 1.0, "", &actions);
    let words = |s: &groundscope::episode::StepRecord| {
        let att = s.attention.as_ref().unwrap();
        att.words.iter().map(|w| format!("{} · ", w.word)).collect()
    };
    check_chart(&d, "/attention/weights", 1.0, "w ", &names_of(&eps, words));
    check_chart(
        &d,
        "/attention/entropy",
        49f32.ln(),
        "H ",
        &names_of(&eps, words),
    );
    // "done" is the last row: its label is inside the chart, above its bar.
    let last = d.labels["/policy/probs"][0].last().unwrap().clone();
    assert!(last.starts_with("done "), "{last}");
}

/// A 17-word mission's w and H charts show their first 8 rows at the size of the action
/// chart's, the rest a drag away, and say so; the action chart shows its 7.
#[test]
fn a_long_missions_bar_charts_scroll_instead_of_overprinting() {
    let ep = episode("bundled:babyai", Some("BabyAI-SynthSeq-v0"), 3);
    let n = ep.tokens.len();
    assert!(n > 8, "a long mission: {}", ep.mission);
    let d = recorded(std::slice::from_ref(&ep));
    let words = |s: &groundscope::episode::StepRecord| {
        let att = s.attention.as_ref().unwrap();
        att.words.iter().map(|w| format!("{} · ", w.word)).collect()
    };
    check_chart(
        &d,
        "/attention/weights",
        1.0,
        "w ",
        &names_of(std::slice::from_ref(&ep), words),
    );
    let pitch = d.points["/policy/probs"][0][1][1] - d.points["/policy/probs"][0][0][1];
    let rows_shown = |title: &str| {
        let b = d
            .view_bounds
            .get(title)
            .unwrap_or_else(|| panic!("bounds for {title:?} in {:?}", d.view_bounds));
        ((b[3] - b[2]) / f64::from(pitch)).floor() as usize
    };
    for title in [
        format!("weights w, 8 of {n}"),
        format!("entropies H (nats), 8 of {n}"),
    ] {
        assert!(
            d.view_names.contains(&title),
            "{title:?} in {:?}",
            d.view_names
        );
        assert_eq!(rows_shown(&title), 8, "{title}");
    }
    assert_eq!(rows_shown("action probabilities"), 7);
}

/// A 22×22 world is in view whole, its legend is text beside it rather than a title the
/// panel cuts, a long mission's map titles are short and their labels leave the word to the
/// title, and the text logs spend their width on the text.
#[test]
fn a_big_world_and_a_long_mission_fit_their_views() {
    let mut ep = episode("bundled:babyai", Some("BabyAI-BossLevel-v0"), 3);
    // The layout does not depend on the episode's length: its first steps will do.
    ep.steps.truncate(20);
    let (w, h) = (ep.final_world.grid.width(), ep.final_world.grid.height());
    assert_eq!((w, h), (22, 22));
    let d = recorded(std::slice::from_ref(&ep));
    let tile = f64::from(groundscope::record::scene::TILE_PX);
    assert_eq!(
        d.view_bounds.get("world"),
        Some(&[0.0, 22.0 * tile, 0.0, 22.0 * tile]),
        "{:?}",
        d.view_bounds
    );
    assert!(d.view_names.contains("world legend"));
    assert!(
        d.view_names.iter().all(|n| !n.starts_with("world (")),
        "no legend in a title: {:?}",
        d.view_names
    );
    let legend = &d.texts["/world/legend"];
    assert!(legend[0].contains("magenta corners") && legend[0].contains("trail"));
    assert!(d.static_entities.contains("/world/legend"));
    for log in ["actions", "expert (minigrid's bot): its action and plan"] {
        assert_eq!(
            d.hidden_log_columns.get(log).map(Vec::as_slice),
            Some(["EntityPath".to_owned(), "LogLevel".to_owned()].as_slice()),
            "{log}: {:?}",
            d.hidden_log_columns
        );
    }
    // BossLevel seed 3's mission repeats "the": those maps are titled by position.
    let folded = folded_words(&roles_of(&ep.final_world), ep.words().len(), None);
    for (i, word) in ep.words().iter().enumerate() {
        let under = if folded[i] { "function_words" } else { "words" };
        let path = format!("/attention/{under}/{i}_{word}/label");
        for label in &d.labels[&path] {
            assert!(label[0].starts_with("w "), "{path}: {label:?}");
            assert!(label[0].contains(" · H "), "{path}: {label:?}");
        }
        let repeated = ep.words().iter().filter(|w| *w == word).count() > 1;
        let title = if repeated {
            format!("{i}:{word}")
        } else {
            (*word).to_owned()
        };
        assert!(
            d.view_names.contains(&title),
            "{title:?} in {:?}",
            d.view_names
        );
        assert!(title.chars().count() <= 9, "{title}");
    }
}

/// A long mission's recording follows the debugger's rule ([`folded_words`], the one
/// function both use): the content words' maps are in view, and each function word's map is
/// kept under `attention/function_words/`, its view hidden in the layout, whose grid it then
/// leaves to the others; the words table marks it folded.
#[test]
fn a_long_missions_function_words_fold_out_of_view_as_in_the_debugger() {
    let mut ep = episode("bundled:babyai", Some("BabyAI-BossLevel-v0"), 3);
    ep.steps.truncate(12);
    let words = ep.words();
    assert!(
        words.len() > FOLD_ABOVE_WORDS,
        "a long mission: {}",
        ep.mission
    );
    let folded = folded_words(&roles_of(&ep.final_world), words.len(), None);
    let n_folded = folded.iter().filter(|f| **f).count();
    assert!(
        n_folded > 0 && n_folded < words.len(),
        "some words fold, not all: {folded:?}"
    );
    let d = recorded(std::slice::from_ref(&ep));
    let title = |i: usize, w: &str| {
        if words.iter().filter(|x| **x == w).count() > 1 {
            format!("{i}:{w}")
        } else {
            w.to_owned()
        }
    };
    for (i, (w, &f)) in words.iter().zip(&folded).enumerate() {
        let shown = format!("/attention/words/{i}_{w}");
        let kept = format!("/attention/function_words/{i}_{w}");
        let (here, not_here) = if f { (&kept, &shown) } else { (&shown, &kept) };
        assert_eq!(
            rows(&d, here, "DepthImage:buffer"),
            ep.steps.len(),
            "{here}: a map at every step"
        );
        assert_eq!(rows(&d, not_here, "DepthImage:buffer"), 0, "{not_here}");
        let t = title(i, w);
        assert!(d.view_names.contains(&t), "{t:?} in {:?}", d.view_names);
        assert_eq!(
            d.hidden_views.contains(&t),
            f,
            "{t:?}: hidden iff folded ({:?})",
            d.hidden_views
        );
    }
    // Nothing else is hidden: M, the bars, the text views.
    assert_eq!(d.hidden_views.len(), n_folded, "{:?}", d.hidden_views);
    let legend = &d.texts["/attention/legend"][0];
    assert_eq!(legend.matches("(folded)").count(), n_folded, "{legend}");
}
