//! What each word of a mission names: its clause, which of the clause's descriptions, and its
//! class — a type, a colour, "door", a location, or a word that names nothing by itself (verbs,
//! articles, "next", "then", "you"). The roles follow the instruction tree's own surface
//! (`Instr::surface`), so the i-th role is the i-th word BabyAI's tokenizer splits the mission
//! into; the metrics read them to decide which cells each word's map should cover.

use serde::{Deserialize, Serialize};

use super::instr::{Instr, SeqKind};
use super::mission::{Loc, ObjDesc, TaskKind};
use super::object::ObjectKind;
use super::tree::{Stage, clause_stages};

/// The class of a mission word.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WordClass {
    /// An object type, "ball", "box", "key" or "object".
    Object,
    /// A colour, of an object or of a door.
    Color,
    /// "door".
    Door,
    /// The word that says where: "front", "behind", "left", "right".
    Location,
    /// "goal" (MiniGrid's goal cells).
    Goal,
    /// "lava" (MiniGrid's lava cells).
    Lava,
    /// "opening" (the gap of a MiniGrid wall river).
    Opening,
    /// Verbs, articles and the words joining clauses: shown, never scored.
    Other,
}

/// One word's role in its mission.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WordRole {
    /// Its class.
    pub class: WordClass,
    /// The clause it belongs to, in reading order ([`Instr::clauses`]); `None` for the words
    /// joining clauses.
    pub clause: Option<usize>,
    /// The description it is part of: the clause's own (`desc`), or PutNext's second
    /// (`fixed`); `None` for verbs and joining words.
    pub desc: Option<DescPart>,
}

/// Which description of a clause a word is part of.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DescPart {
    /// The clause's description (PutNext: the object to move).
    Desc,
    /// PutNext's second description, the object to put the first next to.
    Fixed,
}

impl WordRole {
    fn other(clause: Option<usize>) -> Self {
        Self {
            class: WordClass::Other,
            clause,
            desc: None,
        }
    }
}

/// The role of every word of `world`'s mission: its instruction's ([`word_roles`]) on BabyAI's
/// levels, the mission's own words on MiniGrid's environments, whose missions are not BabyAI
/// instructions ([`crate::env::minigrid::words::mission_roles`]).
pub fn roles_of(world: &crate::env::World) -> Vec<WordRole> {
    if world.rules.is_some() {
        return crate::env::minigrid::words::mission_roles(&world.mission);
    }
    word_roles(&world.instr)
}

/// The role of every word of `instr`'s mission, in reading order.
pub fn word_roles(instr: &Instr) -> Vec<WordRole> {
    let mut out = Vec::new();
    let mut clause = 0;
    push_roles(instr, &mut clause, &mut out);
    out
}

fn push_roles(instr: &Instr, clause: &mut usize, out: &mut Vec<WordRole>) {
    match instr {
        Instr::Action(n) => {
            let c = Some(*clause);
            *clause += 1;
            let verb_words = match n.instr.task {
                TaskKind::GoTo | TaskKind::Pickup => 2,
                TaskKind::Open | TaskKind::PutNext => 1,
            };
            out.extend((0..verb_words).map(|_| WordRole::other(c)));
            desc_roles(n.instr.desc, c, DescPart::Desc, out);
            if let Some(fixed) = n.instr.fixed {
                out.extend([WordRole::other(c), WordRole::other(c)]); // "next to"
                desc_roles(fixed, c, DescPart::Fixed, out);
            }
        }
        Instr::Seq(s) => {
            push_roles(&s.a, clause, out);
            let joiner = match s.kind {
                SeqKind::And | SeqKind::Before => 1, // "and", "then"
                SeqKind::After => 2,                 // "after you"
            };
            out.extend((0..joiner).map(|_| WordRole::other(None)));
            push_roles(&s.b, clause, out);
        }
    }
}

/// `ObjDesc.surface`'s words: article, [colour], type, [location phrase].
fn desc_roles(d: ObjDesc, clause: Option<usize>, part: DescPart, out: &mut Vec<WordRole>) {
    let role = |class| WordRole {
        class,
        clause,
        desc: Some(part),
    };
    out.push(role(WordClass::Other)); // "the" / "a"
    if d.color.is_some() {
        out.push(role(WordClass::Color));
    }
    out.push(role(if d.kind == Some(ObjectKind::Door) {
        WordClass::Door
    } else {
        WordClass::Object
    }));
    match d.loc {
        // "in front of you": "front" says where.
        Some(Loc::Front) => out.extend([
            role(WordClass::Other),
            role(WordClass::Location),
            role(WordClass::Other),
            role(WordClass::Other),
        ]),
        // "behind you".
        Some(Loc::Behind) => out.extend([role(WordClass::Location), role(WordClass::Other)]),
        // "on your left" / "on your right".
        Some(Loc::Left | Loc::Right) => out.extend([
            role(WordClass::Other),
            role(WordClass::Other),
            role(WordClass::Location),
        ]),
        None => {}
    }
}

/// The indices of the clauses at `stage`.
fn at_stage(instr: &Instr, stage: Stage) -> Vec<usize> {
    clause_stages(instr)
        .into_iter()
        .enumerate()
        .filter(|(_, s)| *s == stage)
        .map(|(i, _)| i)
        .collect()
}

/// The clauses the verifier is waiting on, in reading order: the one clause; Before's first
/// part until it succeeded, then its second; After's second part first; both parts of And
/// until each succeeded.
pub fn pending_clauses(instr: &Instr) -> Vec<usize> {
    at_stage(instr, Stage::Waiting)
}

/// The clauses of the parts a sequence has not reached yet, in reading order: Before's second
/// part while its first is pending, After's first part while its second is. Acting on one of
/// their objects now is doing the clauses in the wrong order.
pub fn future_clauses(instr: &Instr) -> Vec<usize> {
    at_stage(instr, Stage::Later)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::instr::{Status, parse_mission};
    use crate::env::vocab::split_words;

    fn classes(text: &str) -> Vec<(String, WordClass, Option<usize>)> {
        let roles = word_roles(&parse_mission(text).unwrap());
        let words = split_words(text);
        assert_eq!(roles.len(), words.len(), "{text}");
        words
            .into_iter()
            .zip(roles)
            .map(|(w, r)| (w, r.class, r.clause))
            .collect()
    }

    #[test]
    fn every_word_gets_the_role_its_place_in_the_grammar_gives_it() {
        use WordClass::{Color, Door, Location, Object, Other};
        let c = classes("open the red door, then put a ball on your left next to the grey key");
        let want = [
            ("open", Other, Some(0)),
            ("the", Other, Some(0)),
            ("red", Color, Some(0)),
            ("door", Door, Some(0)),
            ("then", Other, None),
            ("put", Other, Some(1)),
            ("a", Other, Some(1)),
            ("ball", Object, Some(1)),
            ("on", Other, Some(1)),
            ("your", Other, Some(1)),
            ("left", Location, Some(1)),
            ("next", Other, Some(1)),
            ("to", Other, Some(1)),
            ("the", Other, Some(1)),
            ("grey", Color, Some(1)),
            ("key", Object, Some(1)),
        ];
        let got: Vec<_> = c.iter().map(|(w, k, i)| (w.as_str(), *k, *i)).collect();
        assert_eq!(got, want);
        let roles =
            word_roles(&parse_mission("put a ball on your left next to the grey key").unwrap());
        assert_eq!(roles[2].desc, Some(DescPart::Desc));
        assert_eq!(roles[9].desc, Some(DescPart::Fixed));
        let c = classes("go to a box in front of you after you pick up the key behind you");
        assert_eq!(c[5].1, Location, "front");
        assert_eq!((c[10].0.as_str(), c[10].1), ("pick", Other));
        assert_eq!((c[14].0.as_str(), c[14].1), ("behind", Location));
    }

    #[test]
    fn the_verifier_waits_on_the_clause_the_sequence_is_at() {
        let mut t = parse_mission("go to the red ball, then pick up a key").unwrap();
        assert_eq!(pending_clauses(&t), [0]);
        if let Instr::Seq(s) = &mut t {
            s.a_done = Status::Success;
        }
        assert_eq!(pending_clauses(&t), [1]);
        assert_eq!(future_clauses(&t), Vec::<usize>::new());
        let t = parse_mission("go to the red ball after you pick up a key").unwrap();
        assert_eq!(pending_clauses(&t), [1], "After: its second part first");
        assert_eq!(future_clauses(&t), [0]);
        let mut t = parse_mission("go to the red ball and pick up a key").unwrap();
        assert_eq!(pending_clauses(&t), [0, 1]);
        if let Instr::Seq(s) = &mut t {
            s.b_done = Status::Success;
        }
        assert_eq!(pending_clauses(&t), [0]);
        let t = parse_mission("open the door and go to a box, then pick up the key").unwrap();
        assert_eq!(pending_clauses(&t), [0, 1]);
        assert_eq!(future_clauses(&t), [2]);
    }
}
