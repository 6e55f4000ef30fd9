//! minigrid's bot as an agent (`--checkpoint bot`) and as the expert beside any agent: the
//! trace's `expert_action`, the recordings, `eval`'s agreement columns, and what the bot
//! refuses.

use crate::common::{self, assert_bad_input, gs, stderr};
use groundscope::episode::{ActionMode, EpisodeSpec, initial_world, run_from};
use groundscope::policy::Agent;
use groundscope::record::{RerunTargets, record_rerun, write_mcap};
use serde_json::Value;

fn trace_of(args: &[&str]) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.json");
    let mut all = vec!["replay"];
    all.extend_from_slice(args);
    all.extend(["--trace", path.to_str().unwrap()]);
    let o = gs(&all);
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap()
}

/// The bot reads every level's words: it solves PutNextLocal, a level the bundled pair
/// cannot read, and every action it takes is its own expert's.
#[test]
fn the_bot_as_an_agent_solves_a_level_the_bundled_pair_cannot_read() {
    let o = gs(&[
        "replay",
        "--checkpoint",
        "bundled:attention",
        "--level",
        "BabyAI-PutNextLocal-v0",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let t = trace_of(&[
        "--checkpoint",
        "bot",
        "--level",
        "BabyAI-PutNextLocal-v0",
        "--seed",
        "3",
    ]);
    assert_eq!(t["success"], true);
    assert_eq!(t["checkpoint"], "bot");
    let steps = t["steps"].as_array().unwrap();
    assert!(steps.len() > 3);
    for s in steps {
        assert_eq!(s["action"], s["expert_action"], "{s:?}");
        assert!(s["attention"].is_null());
        assert!(!s["expert_plan"].as_str().unwrap().is_empty());
    }
    assert!(
        steps[0]["expert_plan"]
            .as_str()
            .unwrap()
            .contains("(PutNext)"),
        "{}",
        steps[0]["expert_plan"]
    );
}

/// Beside a trained agent every step carries the bot's action; where the agent took
/// another, the bot replans around it (as minigrid's bot does in the mixed fixtures), so
/// its suggestion is still an action.
#[test]
fn every_step_of_any_agent_carries_the_experts_action() {
    let t = trace_of(&["--checkpoint", "bundled:baseline", "--seed", "5"]);
    let steps = t["steps"].as_array().unwrap();
    assert!(!steps.is_empty());
    for s in steps {
        let a = s["expert_action"]
            .as_u64()
            .expect("an action at every step");
        assert!(a < 7);
    }
    // The bot's own episode from the same start is what an agent's steps are compared with
    // (in the paper's done-action mode it fails pickups: it drops what it picked up, docs/bot.md).
    let level = groundscope::env::LevelConfig::default();
    let world = level.generate(5).unwrap();
    let (bot_len, _) = groundscope::bot::solo_length(world).unwrap();
    assert!(bot_len > 0);
}

/// `eval --checkpoint bot`: the bot agrees with itself at every step, its path efficiency is 1
/// on every success, and episodes.csv carries the columns.
#[test]
fn eval_reports_agreement_divergence_and_efficiency() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bot");
    let o = gs(&[
        "eval",
        "--checkpoint",
        "bot",
        "--levels",
        "BabyAI-GoToLocal-v0,BabyAI-UnlockLocal-v0",
        "--seeds",
        "2",
        "--episodes",
        "8",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let cells = report["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 2);
    for c in cells {
        assert_eq!(c["success"]["mean"], 1.0, "{c}");
        assert_eq!(c["expert"]["agreement"]["mean"], 1.0, "{c}");
        assert_eq!(c["expert"]["path_efficiency"]["mean"], 1.0, "{c}");
        assert_eq!(c["expert"]["bot_success"]["mean"], 1.0, "{c}");
        assert!(
            c["expert"]["first_divergence"]["mean"].is_null(),
            "no failure: {c}"
        );
    }
    let mut rd = csv::Reader::from_path(out.join("episodes.csv")).unwrap();
    let header = rd.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = rd.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 32);
    for r in &rows {
        assert_eq!(&r[col("expert_agreement")], "1.000000");
        assert_eq!(&r[col("first_divergence")], "");
        assert_eq!(&r[col("steps")], &r[col("bot_steps")]);
        assert_eq!(&r[col("path_efficiency")], "1.000000");
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("| agree | diverge | efficiency | bot |"),
        "{md}"
    );
}

/// An agent that fails diverges from the bot: the first divergence of a failed episode is
/// the first step whose action differs from the bot's, and agreement is below 1.
#[test]
fn a_failing_agent_leaves_the_experts_plan_where_the_trace_says() {
    let agent = Agent::load("bundled:attention").unwrap();
    let level = groundscope::env::LevelConfig::babyai(
        groundscope::env::LevelId::parse("BabyAI-GoTo-v0").unwrap(),
        false,
    );
    let mut checked = 0;
    for seed in 0..20 {
        let spec = EpisodeSpec {
            level,
            seed,
            mission: None,
            mode: ActionMode::Greedy,
        };
        let trace = run_from(agent.acting(), "a", &spec, initial_world(&spec).unwrap()).unwrap();
        let first = trace
            .steps
            .iter()
            .position(|s| s.expert_action.is_some_and(|a| a != s.action));
        if trace.success() || first.is_none() {
            continue;
        }
        let eps = groundscope::metrics::sweep::evaluate_episodes(
            agent.acting(),
            &level,
            &[(0, seed)],
            0.5,
            ActionMode::Greedy,
            &mut |_| {},
        )
        .unwrap();
        let e = &eps[0].expert;
        // The sweep and the trace agree on the first divergence that costs something, which
        // is never before the first disagreement.
        let costly = groundscope::metrics::failure::first_divergence(&trace);
        assert_eq!(e.first_divergence, costly);
        if let Some(t) = costly {
            assert!(t as usize >= first.unwrap());
            let s = &trace.steps[t as usize];
            assert!(groundscope::bot::divergence_matters(
                &s.world,
                s.action,
                s.expert_action.unwrap()
            ));
        }
        assert!(e.agreement() < 1.0);
        assert_eq!(
            e.steps as usize,
            trace
                .steps
                .iter()
                .filter(|s| s.expert_action.is_some())
                .count()
        );
        checked += 1;
    }
    assert!(
        checked > 0,
        "no failed episode of the bundled model on GoTo in 20 seeds"
    );
}

/// A divergence matters only where it costs the bot steps: turning the other way than the bot
/// at the start of GoToLocal is a tie where both turns reach the target in as many steps, and
/// costs something where one side is nearer; taking the bot's own action never matters.
#[test]
fn a_divergence_matters_only_where_it_costs_the_bot_steps() {
    use groundscope::bot::{Expert, divergence_matters, solo_length};
    use groundscope::env::Action;
    let level = groundscope::env::LevelConfig::babyai(
        groundscope::env::LevelId::parse("BabyAI-GoToLocal-v0").unwrap(),
        false,
    );
    let (mut ties, mut costly) = (0, 0);
    for seed in 0..300 {
        let world = level.generate(seed).unwrap();
        let advised = Expert::new(&world)
            .advise(&world, &world.observe())
            .unwrap();
        assert!(!divergence_matters(&world, advised, advised));
        let other = match advised {
            Action::Left => Action::Right,
            Action::Right => Action::Left,
            _ => continue,
        };
        // The bot's own steps to success after each turn, counted here step by step.
        let after = |a: Action| {
            let mut w = world.clone();
            w.step(a).unwrap();
            solo_length(w).filter(|&(_, ok)| ok).map(|(n, _)| n)
        };
        let (t, a) = (after(other).unwrap(), after(advised).unwrap());
        assert_eq!(
            divergence_matters(&world, other, advised),
            t > a,
            "seed {seed}"
        );
        if t > a { costly += 1 } else { ties += 1 }
    }
    assert!(ties > 0 && costly > 0, "ties {ties}, costly {costly}");
}

/// The recordings carry the expert: MCAP's `/policy` has its action and plan at every step,
/// the `.rrd` logs `policy/expert` at every step.
#[test]
fn recordings_carry_the_expert() {
    let agent = Agent::load("bot").unwrap();
    let level = groundscope::env::LevelConfig::babyai(
        groundscope::env::LevelId::parse("BabyAI-UnlockLocal-v0").unwrap(),
        false,
    );
    let spec = EpisodeSpec {
        level,
        seed: 2,
        mission: None,
        mode: ActionMode::Greedy,
    };
    let ep = run_from(agent.acting(), "bot", &spec, initial_world(&spec).unwrap()).unwrap();
    assert!(ep.success());
    let dir = tempfile::tempdir().unwrap();
    let mcap_path = dir.path().join("bot.mcap");
    write_mcap(std::slice::from_ref(&ep), &mcap_path, 0.5, None).unwrap();
    let bytes = std::fs::read(&mcap_path).unwrap();
    let mut n = 0;
    for msg in mcap::MessageStream::new(&bytes).unwrap() {
        let msg = msg.unwrap();
        if msg.channel.topic == "/policy" {
            let v: Value = serde_json::from_slice(&msg.data).unwrap();
            let s = &ep.steps[n];
            assert_eq!(
                v["expert_action"],
                s.expert_action.map(|a| a as u8).unwrap()
            );
            assert_eq!(v["expert_plan"], s.expert_plan.as_str());
            assert_eq!(v["left_expert"], false);
            n += 1;
        }
    }
    assert_eq!(n, ep.steps.len());
    let rrd = dir.path().join("bot.rrd");
    record_rerun(
        std::slice::from_ref(&ep),
        &RerunTargets {
            save: Some(rrd.clone()),
            spawn: false,
            connect: None,
        },
        0.5,
        None,
    )
    .unwrap();
    let d = common::rrd::decode(&rrd);
    assert_eq!(
        common::rrd::rows(&d, "/policy/expert", "TextLog:text"),
        ep.steps.len()
    );
    let status = d.texts.get("/policy/status").cloned().unwrap_or_default();
    assert_eq!(status.len(), ep.steps.len(), "{:?}", d.texts.keys());
    assert!(
        status
            .iter()
            .all(|t| t.contains("expert (minigrid's bot) **")),
        "{status:?}"
    );
}

/// Faithfulness probes a network; the bot has none.
#[test]
fn faithfulness_refuses_the_bot() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f");
    let mut args = vec!["faithfulness", "--checkpoint", "bot"];
    args.extend(common::SMALL_SWEEP);
    args.extend(["--out", out.to_str().unwrap()]);
    let o = gs(&args);
    assert_bad_input(&o, "bot has no network");
    assert!(!dir.path().join("f").exists());
}

/// A failing agent's episodes open where they were lost: episodes.csv's `decisive_step` is the
/// first divergence that mattered, else the last step (GoToLocal has no sequence to get out of
/// order), and report.md's `view` command opens the worst failures there.
#[test]
fn failures_open_at_their_decisive_step() {
    let dir = tempfile::tempdir().unwrap();
    let ckpt = dir.path().join("fresh");
    let o = gs(&[
        "init",
        "--level",
        "BabyAI-GoToLocal-v0",
        "--out",
        ckpt.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("report");
    let o = gs(&[
        "eval",
        "--checkpoint",
        ckpt.to_str().unwrap(),
        "--levels",
        "BabyAI-GoToLocal-v0",
        "--seeds",
        "1",
        "--episodes",
        "6",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = common::csv_rows(&out.join("episodes.csv"));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let mut failed = 0;
    for r in &rows {
        if r["success"] == "1" {
            assert_eq!(r["decisive_step"], "");
            continue;
        }
        failed += 1;
        let want = if r["first_divergence"].is_empty() {
            (r["steps"].parse::<u32>().unwrap() - 1).to_string()
        } else {
            r["first_divergence"].clone()
        };
        assert_eq!(r["decisive_step"], want, "{r:?}");
        let view = format!("--seed {} --step {want}", r["level_seed"]);
        assert!(md.contains(&view), "no `{view}` in report.md");
    }
    assert!(failed > 0, "a fresh model failed no GoToLocal episode");
}
