//! Recordings of BabyAI levels carry the instruction tree the debugger shows: `mission/tree`
//! and the numbered clause targets in Rerun, `/instruction` in MCAP, read back from the files
//! — episodes long enough to be written in several blocks of steps.

use crate::common::rrd::{decode, rows};
use groundscope::env::level::{LevelConfig, LevelId};
use groundscope::env::tree::InstructionTree;
use groundscope::env::{DoorState, Instr};
use groundscope::episode::{ActionMode, EpisodeSpec, EpisodeTrace, run_episode};
use groundscope::record::scene::{ClauseMark, clause_marks};
use groundscope::record::{RerunTargets, SCENE_BLOCK, record_rerun, write_mcap};

/// An episode of an untrained attention model of all of BabyAI's words on `id`, at the first
/// seed whose world `pick` accepts.
fn episode(id: &str, pick: impl Fn(&groundscope::env::World) -> bool) -> EpisodeTrace {
    let level = LevelConfig::babyai(LevelId::parse(id).unwrap(), false);
    let ckpt = crate::common::fresh_attention(level);
    let seed = (0..100)
        .find(|&s| pick(&level.generate(s).unwrap()))
        .expect("a seed in 100");
    let spec = EpisodeSpec {
        level,
        seed,
        mission: None,
        mode: ActionMode::Greedy,
    };
    run_episode(&ckpt, "fresh", &spec).unwrap()
}

/// The trees of the steps where it changed (the first step's always): what a recording logs.
fn changed_trees(ep: &EpisodeTrace) -> Vec<InstructionTree> {
    let mut out: Vec<InstructionTree> = Vec::new();
    for s in &ep.steps {
        let t = InstructionTree::of(&s.world);
        if out.last() != Some(&t) {
            out.push(t);
        }
    }
    out
}

/// The clause marks of each step, one entry each time they change.
fn changed_marks(ep: &EpisodeTrace) -> Vec<Vec<ClauseMark>> {
    let mut out: Vec<Vec<ClauseMark>> = Vec::new();
    for s in &ep.steps {
        let m = clause_marks(&InstructionTree::of(&s.world), &s.world);
        if out.last() != Some(&m) {
            out.push(m);
        }
    }
    out
}

#[test]
fn a_rerun_recording_carries_the_instruction_tree_and_the_clause_targets() {
    let ep = episode("BabyAI-GoToSeqS5R2-v0", |w| {
        matches!(w.instr, Instr::Seq(_))
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("seq.rrd");
    let targets = RerunTargets {
        save: Some(path.clone()),
        ..RerunTargets::default()
    };
    record_rerun(std::slice::from_ref(&ep), &targets, 0.5, None).unwrap();
    // Recorded block by block: a mark logged only where it changed must not be logged
    // again at a block's first step.
    assert!(
        ep.steps.len() > 4 * SCENE_BLOCK,
        "{} steps: too few to cross blocks",
        ep.steps.len()
    );
    let d = decode(&path);
    let trees = changed_trees(&ep);
    let texts = &d.texts["/mission/tree"];
    let want: Vec<String> = trees.iter().map(InstructionTree::markdown).collect();
    assert_eq!(texts, &want, "one row each time the tree changes");
    assert!(
        texts[0].contains("**"),
        "the clause waited on in bold: {}",
        texts[0]
    );
    // The clause targets: numbered by clause, one label per target cell on the grid, logged
    // each time the marks change, written beside the target (not over it) where a cell is
    // free.
    let labels = &d.labels["/world/clauses/numbers"];
    let marks = changed_marks(&ep);
    assert_eq!(labels.len(), marks.len());
    let first: Vec<String> = marks[0].iter().map(|m| m.label.clone()).collect();
    assert!(first.len() >= 2, "two clauses' targets: {first:?}");
    assert!(
        marks[0].iter().any(|m| m.label_at != m.pos),
        "{:?}",
        marks[0]
    );
    assert_eq!(
        rows(&d, "/world/clauses", "Boxes2D:half_sizes"),
        marks.len()
    );
    for (row, m) in labels.iter().zip(&marks) {
        let tree = InstructionTree::of(
            &ep.steps[ep
                .steps
                .iter()
                .position(|s| clause_marks(&InstructionTree::of(&s.world), &s.world) == *m)
                .unwrap()]
            .world,
        );
        let n: usize = tree
            .clauses()
            .map(|c| c.targets.iter().filter(|t| t.pos.is_some()).count())
            .sum();
        let named: usize = row.iter().map(|l| l.split(' ').count()).sum();
        assert_eq!(named, n, "every target on the grid numbered once: {row:?}");
    }
    assert_eq!(labels[0], first);
    assert_eq!(
        rows(&d, "/world/marks/targets", "Boxes2D:half_sizes"),
        ep.steps.len()
    );
    assert!(
        d.view_names.contains("instruction (bold: waited on)"),
        "{:?}",
        d.view_names
    );
}

#[test]
fn an_mcap_recording_carries_the_tree_and_the_doors_at_every_step() {
    let ep = episode("BabyAI-UnlockLocal-v0", |_| true);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("doors.mcap");
    assert!(ep.steps.len() > 4 * SCENE_BLOCK, "{} steps", ep.steps.len());
    write_mcap(std::slice::from_ref(&ep), &path, 0.5, None).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let mut got = Vec::new();
    for msg in mcap::MessageStream::new(&bytes).unwrap() {
        let msg = msg.unwrap();
        if msg.channel.topic == "/instruction" {
            assert_eq!(
                msg.channel.schema.as_ref().unwrap().name,
                "groundscope.Instruction"
            );
            got.push(serde_json::from_slice::<serde_json::Value>(&msg.data).unwrap());
        }
    }
    assert_eq!(got.len(), ep.steps.len(), "one message per step");
    for (k, (v, s)) in got.iter().zip(&ep.steps).enumerate() {
        let tree = InstructionTree::of(&s.world);
        assert_eq!(v["step"], k);
        assert_eq!(v["nodes"], serde_json::to_value(&tree.nodes).unwrap());
        assert_eq!(v["doors"], serde_json::to_value(&tree.doors).unwrap());
    }
    assert_eq!(got[0]["nodes"][0]["stage"], "waiting");
    assert!(
        InstructionTree::of(&ep.steps[0].world)
            .doors
            .iter()
            .any(|d| d.state == DoorState::Locked)
    );
    let doors = got[0]["doors"].as_array().unwrap();
    assert!(doors.iter().any(|d| d["state"] == "locked"), "{doors:?}");
}
