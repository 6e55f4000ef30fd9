//! The instruction as a tree, the way a person reads where the agent is in it: each sequence
//! and clause with its stage (done, waited on, later), each clause's targets and where they are
//! now, and the doors with their states. The debugger draws it, and the Rerun and MCAP
//! recordings carry it, all from [`InstructionTree::of`], so the three never disagree.
//!
//! The stages are the verifier's own: they decide which objects `M` is scored on
//! ([`pending_target_ids`]) and which acts are done in the wrong order
//! ([`super::roles::future_clauses`]).

use std::fmt::Write as _;

use serde::Serialize;

use super::grid::Pos;
use super::instr::{Instr, SeqKind, Status};
use super::object::{Color, DoorState, ObjectId, ObjectKind, WorldObj};
use super::roles::DescPart;
use super::world::World;

/// Where the verifier stands with a clause or a sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// Its part of the sequence is done.
    Done,
    /// The verifier is waiting on it.
    Waiting,
    /// Its part comes later: the sequence has not reached it.
    Later,
}

impl Stage {
    /// `"done"`, `"waiting"` or `"later"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Done => "done",
            Self::Waiting => "waiting",
            Self::Later => "later",
        }
    }
}

/// One object a clause's description matched at reset.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TreeTarget {
    /// The object, e.g. `"red ball"`.
    pub object: String,
    /// Its cell now; `None` while the agent carries it.
    pub pos: Option<Pos>,
    /// Which of the clause's descriptions matched it (PutNext: `fixed` for the objects to put
    /// the first next to).
    pub part: DescPart,
    /// Whether it is one of `M`'s targets now ([`pending_target_ids`]).
    pub pending: bool,
}

/// One node of the tree, in reading order (a sequence before its two parts).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TreeNode {
    /// Nesting depth, 0 at the root.
    pub depth: usize,
    /// A clause's words ("pick up a key") or a sequence's joining words ("then", "after you",
    /// "and").
    pub text: String,
    /// The sequence's kind; `None` for a clause.
    pub seq: Option<SeqKind>,
    /// The clause's index in reading order ([`Instr::clauses`]); `None` for a sequence.
    pub clause: Option<usize>,
    /// Where the verifier stands with it.
    pub stage: Stage,
    /// A clause's targets (empty for a sequence).
    pub targets: Vec<TreeTarget>,
}

/// A door of the world and its state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct DoorMark {
    /// Its cell.
    pub pos: Pos,
    /// Its colour.
    pub color: Color,
    /// Open, closed or locked.
    pub state: DoorState,
}

/// The instruction tree of one step, with the world's doors.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct InstructionTree {
    /// The nodes in reading order.
    pub nodes: Vec<TreeNode>,
    /// Every door, in grid scan order.
    pub doors: Vec<DoorMark>,
}

impl InstructionTree {
    /// The tree of `world`'s instruction as its verifier stands now.
    pub fn of(world: &World) -> Self {
        let pending = pending_target_ids(world);
        let mut nodes = Vec::new();
        walk(&world.instr, 0, Stage::Waiting, &mut 0, &mut nodes);
        let clauses = world.instr.clauses();
        // One scan of the grid serves every target's lookup.
        let objects: Vec<(Pos, WorldObj)> = world.grid.objects().collect();
        for node in &mut nodes {
            let Some(c) = node.clause.and_then(|c| clauses.get(c)) else {
                continue;
            };
            let parts = [
                (DescPart::Desc, &c.targets.obj_set),
                (DescPart::Fixed, &c.fixed_targets.obj_set),
            ];
            for (part, ids) in parts {
                node.targets.extend(ids.iter().filter_map(|&id| {
                    let (pos, object) = locate(world, &objects, id)?;
                    Some(TreeTarget {
                        object,
                        pos,
                        part,
                        pending: pending.contains(&id),
                    })
                }));
            }
        }
        let doors = world
            .grid
            .objects()
            .filter(|(_, o)| o.kind == ObjectKind::Door)
            .map(|(pos, o)| DoorMark {
                pos,
                color: o.color,
                state: o.state,
            })
            .collect();
        Self { nodes, doors }
    }

    /// The clause nodes, in reading order.
    pub fn clauses(&self) -> impl Iterator<Item = &TreeNode> {
        self.nodes.iter().filter(|n| n.clause.is_some())
    }

    /// Whether the tree has more to show than the mission line: several clauses or a second
    /// description (PutNext), whose targets a display numbers.
    pub fn is_compound(&self) -> bool {
        self.nodes.len() > 1
            || self
                .clauses()
                .any(|n| n.targets.iter().any(|t| t.part == DescPart::Fixed))
    }

    /// The tree as Markdown: one bullet per node, indented by depth, the clauses waited on in
    /// bold, done ones struck through, each clause's targets with their cells; then the doors.
    pub fn markdown(&self) -> String {
        let mut out = String::new();
        for n in &self.nodes {
            let indent = "  ".repeat(n.depth);
            let text = match n.stage {
                Stage::Waiting => format!("**{}**", n.text),
                Stage::Done => format!("~~{}~~", n.text),
                Stage::Later => n.text.clone(),
            };
            let label = n.clause.map_or_else(String::new, |c| format!("{} ", c + 1));
            let _ = write!(out, "{indent}- {label}{text} — *{}*", n.stage.name());
            if n.clause.is_some() {
                let _ = write!(out, " → {}", targets_text(&n.targets));
            }
            out.push('\n');
        }
        if !self.doors.is_empty() {
            out.push_str("\ndoors: ");
            out.push_str(&doors_text(&self.doors));
            out.push('\n');
        }
        out
    }
}

/// `"red ball (3, 4), grey key (carried)"`; PutNext's second description after "next to".
pub fn targets_text(targets: &[TreeTarget]) -> String {
    let one = |t: &TreeTarget| {
        let at = t
            .pos
            .map_or_else(|| "carried".to_owned(), |(x, y)| format!("{x}, {y}"));
        format!("{} ({at})", t.object)
    };
    let of = |part| {
        targets
            .iter()
            .filter(|t| t.part == part)
            .map(one)
            .collect::<Vec<_>>()
            .join(", ")
    };
    let fixed = of(DescPart::Fixed);
    if fixed.is_empty() {
        of(DescPart::Desc)
    } else {
        format!("{}; next to {fixed}", of(DescPart::Desc))
    }
}

/// `"red (5, 3) locked · grey (10, 7) open"`.
pub fn doors_text(doors: &[DoorMark]) -> String {
    doors
        .iter()
        .map(|d| {
            let state = match d.state {
                DoorState::Open => "open",
                DoorState::Closed => "closed",
                DoorState::Locked => "locked",
            };
            format!("{} ({}, {}) {state}", d.color.name(), d.pos.0, d.pos.1)
        })
        .collect::<Vec<_>>()
        .join(" · ")
}

/// Where object `id` is and what it is: among `objects` (the grid's), or carried (`None`);
/// `None` if gone.
fn locate(
    world: &World,
    objects: &[(Pos, WorldObj)],
    id: ObjectId,
) -> Option<(Option<Pos>, String)> {
    if let Some(o) = world.carrying.as_ref().filter(|o| o.id == id) {
        return Some((None, o.describe()));
    }
    objects
        .iter()
        .find(|(_, o)| o.id == id)
        .map(|(p, o)| (Some(*p), o.describe()))
}

/// Pushes `instr`'s nodes at `stage`, numbering clauses from `clause`. Only a part the
/// verifier waits on splits further; a done or later part's clauses are all done or all later.
fn walk(instr: &Instr, depth: usize, stage: Stage, clause: &mut usize, out: &mut Vec<TreeNode>) {
    match instr {
        Instr::Action(n) => {
            out.push(TreeNode {
                depth,
                text: n
                    .instr
                    .surface_with(n.targets.obj_set.len(), n.fixed_targets.obj_set.len()),
                seq: None,
                clause: Some(*clause),
                stage,
                targets: Vec::new(),
            });
            *clause += 1;
        }
        Instr::Seq(s) => {
            out.push(TreeNode {
                depth,
                text: match s.kind {
                    SeqKind::And => "and",
                    SeqKind::Before => "then",
                    SeqKind::After => "after you",
                }
                .to_owned(),
                seq: Some(s.kind),
                clause: None,
                stage,
                targets: Vec::new(),
            });
            let done = |d: Status| {
                if d == Status::Success {
                    Stage::Done
                } else {
                    Stage::Waiting
                }
            };
            let (a_done, b_done) = (done(s.a_done), done(s.b_done));
            let (a, b) = match (stage, s.kind) {
                (Stage::Done | Stage::Later, _) => (stage, stage),
                (Stage::Waiting, SeqKind::And) => (a_done, b_done),
                (Stage::Waiting, SeqKind::Before) if a_done == Stage::Done => (a_done, b_done),
                (Stage::Waiting, SeqKind::Before) => (a_done, Stage::Later),
                (Stage::Waiting, SeqKind::After) if b_done == Stage::Done => (a_done, b_done),
                (Stage::Waiting, SeqKind::After) => (Stage::Later, b_done),
            };
            walk(&s.a, depth + 1, a, clause, out);
            walk(&s.b, depth + 1, b, clause, out);
        }
    }
}

/// Each clause's [`Stage`], in reading order.
pub fn clause_stages(instr: &Instr) -> Vec<Stage> {
    let mut nodes = Vec::new();
    walk(instr, 0, Stage::Waiting, &mut 0, &mut nodes);
    nodes
        .into_iter()
        .filter(|n| n.clause.is_some())
        .map(|n| n.stage)
        .collect()
}

/// The objects the clauses the verifier is waiting on matched
/// ([`super::roles::pending_clauses`]), the targets of `M` and of the failure classes.
/// PutNext waits on the object to move until the agent carries one, then on the objects to put
/// it next to.
pub fn pending_target_ids(world: &World) -> Vec<ObjectId> {
    let clauses = world.instr.clauses();
    let carried = world.carrying.as_ref().map(|o| o.id);
    let mut ids = Vec::new();
    for c in super::roles::pending_clauses(&world.instr) {
        let Some(node) = clauses.get(c) else { continue };
        let moving = node.instr.fixed.is_some()
            && carried.is_some_and(|id| node.targets.obj_set.contains(&id));
        let set = if moving {
            &node.fixed_targets
        } else {
            &node.targets
        };
        ids.extend_from_slice(&set.obj_set);
    }
    ids
}

/// The cells of `M`'s targets now ([`pending_target_ids`] on the grid): what the world
/// pictures outline.
pub fn pending_target_cells(world: &World) -> Vec<Pos> {
    let ids = pending_target_ids(world);
    world
        .grid
        .objects()
        .filter(|(_, o)| ids.contains(&o.id))
        .map(|(p, _)| p)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::level::babyai_world as world;

    #[test]
    fn a_sequence_shows_its_parts_with_the_clause_waited_on_and_their_targets() {
        // Find a BeforeInstr among SynthSeq's seeds: its first part waited on, its second later.
        let w = (0..200)
            .map(|s| world("BabyAI-SynthSeq-v0", s))
            .find(|w| matches!(&w.instr, Instr::Seq(s) if s.kind == SeqKind::Before))
            .expect("a Before sequence in 200 seeds");
        let t = InstructionTree::of(&w);
        assert_eq!(t.nodes[0].seq, Some(SeqKind::Before));
        assert_eq!(t.nodes[0].text, "then");
        let clauses: Vec<_> = t.clauses().collect();
        assert_eq!(clauses.len(), w.instr.clauses().len());
        assert_eq!(clauses[0].stage, Stage::Waiting);
        assert!(clauses.iter().skip(1).any(|c| c.stage == Stage::Later));
        assert!(t.is_compound());
        // Every clause lists what its descriptions matched; the ones waited on are M's.
        let pending = pending_target_ids(&w);
        for c in &clauses {
            assert!(!c.targets.is_empty(), "{}", c.text);
            for tg in &c.targets {
                assert_eq!(
                    tg.pending,
                    c.stage == Stage::Waiting && tg.part == DescPart::Desc
                );
            }
        }
        assert_eq!(
            clauses
                .iter()
                .flat_map(|c| &c.targets)
                .filter(|t| t.pending)
                .count(),
            pending.len()
        );
        let md = t.markdown();
        assert!(md.contains(&format!("**{}**", clauses[0].text)), "{md}");
        assert_eq!(
            clause_stages(&w.instr),
            clauses.iter().map(|c| c.stage).collect::<Vec<_>>()
        );
    }

    #[test]
    fn doors_are_listed_with_their_states_and_a_one_clause_tree_is_not_compound() {
        let w = world("BabyAI-UnlockLocal-v0", 1);
        let t = InstructionTree::of(&w);
        assert!(!t.is_compound());
        assert_eq!(t.nodes.len(), 1);
        assert!(t.doors.iter().any(|d| d.state == DoorState::Locked));
        assert!(t.markdown().contains("locked"), "{}", t.markdown());
        let w = world("BabyAI-PutNextLocal-v0", 1);
        let t = InstructionTree::of(&w);
        assert!(
            t.is_compound(),
            "PutNext's second description is numbered too"
        );
        assert!(targets_text(&t.nodes[0].targets).contains("; next to "));
    }
}
