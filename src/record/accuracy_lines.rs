//! The accuracy lines every display prints under a step: which kinds of word it accounts for,
//! each kind's evaluated map, or a sentence saying why it is not scored at this step.

use crate::env::roles::WordClass;
use crate::env::world::World;
use crate::episode::StepRecord;
use crate::metrics::grounding::{EvaluatedMap, WordKind};

use super::scene::StepScene;

/// Why a kind of grounding accuracy is not shown at this step of `world`: which word it needs
/// and what is missing from the view, said of the clause the verifier is waiting on (named by
/// number on a mission of several clauses), since that is the clause `M` is scored on.
pub fn no_accuracy_reason(kind: WordKind, world: &World) -> String {
    let clauses = world.instr.clauses();
    let waited = crate::env::roles::pending_clauses(&world.instr)
        .first()
        .and_then(|&c| clauses.get(c).map(|n| (c, n.instr.desc)));
    let (desc, clause) = match waited {
        Some((c, d)) => (d, (clauses.len() > 1).then_some(c + 1)),
        None => (world.desc(), None),
    };
    let whose = clause.map_or_else(
        || "the mission".to_owned(),
        |c| format!("clause {c}, the one waited on,"),
    );
    let named = desc_words(desc);
    match kind {
        WordKind::Object => match desc.kind {
            Some(k) => format!("object: no {} in view, nothing to score", k.name()),
            None => format!("object: {whose} names no object type"),
        },
        WordKind::Color => match desc.color {
            Some(c) => format!("color: no {} object in view, nothing to score", c.name()),
            None => format!("color: {whose} names no colour"),
        },
        WordKind::Combined => {
            let carried = world
                .carrying
                .is_some_and(|o| crate::env::tree::pending_target_ids(world).contains(&o.id));
            let pending = crate::env::roles::pending_clauses(&world.instr);
            if pending.len() > 1 {
                // An And waits on both of its clauses: naming one would say the other's
                // targets do not count.
                let each: Vec<String> = pending
                    .iter()
                    .filter_map(|&c| clauses.get(c).map(|n| (c, desc_words(n.instr.desc))))
                    .map(|(c, words)| format!("{words} of clause {}", c + 1))
                    .collect();
                let state = if carried {
                    "carried or not in view"
                } else {
                    "in view"
                };
                return format!(
                    "combined: no target of the clauses waited on ({}) {state}, nothing to score",
                    each.join("; ")
                );
            }
            let of = clause.map_or_else(String::new, |c| format!(" of clause {c}"));
            if carried {
                format!("combined: the target{of} ({named}) is carried, not in view")
            } else {
                format!("combined: no {named} (a target{of}) in view, nothing to score")
            }
        }
        WordKind::Door => "door: no door in view, nothing to score".to_owned(),
        WordKind::Location => {
            "location: none of the objects its description matched is in view".to_owned()
        }
        WordKind::Goal => "goal: no goal in view, nothing to score".to_owned(),
        WordKind::Lava => "lava: no lava in view, nothing to score".to_owned(),
        WordKind::Opening => "opening: no opening in view, nothing to score".to_owned(),
    }
}

/// A description in words: its colour, if any, and its kind (`"red ball"`, `"object"`).
fn desc_words(desc: crate::env::ObjDesc) -> String {
    [
        desc.color.map(crate::env::object::Color::name),
        Some(
            desc.kind
                .map_or("object", crate::env::object::ObjectKind::name),
        ),
    ]
    .into_iter()
    .flatten()
    .collect::<Vec<_>>()
    .join(" ")
}

/// The word kinds a display accounts for at a step of `world` (scores or says why not): `M`
/// always; colour always on BabyAI's levels, as on the paper's ("names no colour" where the
/// mission has none); every other kind only where the mission has such a word (no object
/// line on "go to the red door", whose door word is scored as a door).
pub fn shown_kinds(world: &World) -> Vec<WordKind> {
    let roles = crate::env::roles::roles_of(world);
    let has = |class| roles.iter().any(|r| r.class == class);
    let minigrid = world.rules.is_some();
    WordKind::ALL
        .into_iter()
        .filter(|k| match k {
            WordKind::Object => has(WordClass::Object),
            WordKind::Color => !minigrid || has(WordClass::Color),
            WordKind::Door => has(WordClass::Door),
            WordKind::Location => has(WordClass::Location),
            WordKind::Goal => has(WordClass::Goal),
            WordKind::Lava => has(WordClass::Lava),
            WordKind::Opening => has(WordClass::Opening),
            WordKind::Combined => true,
        })
        .collect()
}

/// Each kind of accuracy a display accounts for at `step` ([`shown_kinds`]): its evaluated map,
/// or why it is not scored ([`no_accuracy_reason`]).
pub fn accuracy_rows<'a>(
    step: &StepRecord,
    scene: &'a StepScene,
) -> Vec<(WordKind, Result<&'a EvaluatedMap, String>)> {
    shown_kinds(&step.world)
        .into_iter()
        .map(|kind| {
            let row = scene
                .grounding
                .iter()
                .find(|g| g.kind == kind)
                .ok_or_else(|| match step.attention {
                    // "no key in view" would be false with the key in view: nothing was scored
                    // because the agent has no maps.
                    None => format!(
                        "{}: this agent has no attention maps to score (see its occlusion map \
                         with --faithfulness)",
                        kind.name()
                    ),
                    Some(_) => no_accuracy_reason(kind, &step.world),
                });
            (kind, row)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::level::babyai_world as world;

    #[test]
    fn a_reason_speaks_of_the_clause_waited_on() {
        // "… after …" waits on its second clause first: a colour named only by the first
        // clause must not be reported as missing from "the mission".
        let mut checked = 0;
        for seed in 0..300 {
            let w = world("BabyAI-GoToSeqS5R2-v0", seed);
            let clauses = w.instr.clauses();
            let Some(&c) = crate::env::roles::pending_clauses(&w.instr).first() else {
                continue;
            };
            let reason = no_accuracy_reason(WordKind::Color, &w);
            match clauses[c].instr.desc.color {
                None => {
                    let want = if clauses.len() > 1 {
                        format!(
                            "color: clause {}, the one waited on, names no colour",
                            c + 1
                        )
                    } else {
                        "color: the mission names no colour".to_owned()
                    };
                    assert_eq!(reason, want, "seed {seed}: {}", w.mission);
                    checked += usize::from(clauses.iter().any(|n| n.instr.desc.color.is_some()));
                }
                Some(col) => assert!(reason.contains(col.name()), "seed {seed}: {reason}"),
            }
        }
        assert!(checked > 0, "no mission whose other clause names a colour");
        // One clause: "the mission", as before.
        let w = world("BabyAI-GoToLocal-v0", 0);
        let r = no_accuracy_reason(WordKind::Combined, &w);
        assert!(
            r.starts_with("combined: no ") && !r.contains("clause"),
            "{r}"
        );
    }

    #[test]
    fn an_and_waiting_on_two_clauses_names_both() {
        let mut checked = 0;
        for seed in 0..400 {
            let w = world("BabyAI-BossLevel-v0", seed);
            let pending = crate::env::roles::pending_clauses(&w.instr);
            if pending.len() < 2 {
                continue;
            }
            let r = no_accuracy_reason(WordKind::Combined, &w);
            for c in &pending {
                assert!(
                    r.contains(&format!("of clause {}", c + 1)),
                    "seed {seed}: {r}"
                );
            }
            checked += 1;
        }
        assert!(checked > 0, "no And in 400 BossLevel seeds");
    }

    #[test]
    fn an_agent_without_maps_is_not_told_its_targets_are_out_of_view() {
        let ckpt = crate::policy::bundled::load("bundled:baseline").unwrap();
        let net = crate::policy::Net::new(ckpt.meta.model, ckpt.params.detached()).unwrap();
        let spec = crate::episode::EpisodeSpec {
            level: ckpt.meta.level,
            seed: 3,
            mission: None,
            mode: crate::episode::ActionMode::Greedy,
        };
        let start = crate::episode::initial_world(&spec).unwrap();
        let trace = crate::episode::run_from(&net, "b", &spec, start).unwrap();
        let step = &trace.steps[0];
        assert!(step.attention.is_none());
        let scene = StepScene::new(step, 0.5);
        let rows = accuracy_rows(step, &scene);
        assert!(!rows.is_empty());
        for (kind, row) in rows {
            let reason = row.expect_err("nothing is scored without maps");
            assert!(reason.contains("no attention maps"), "{kind:?}: {reason}");
            assert!(!reason.contains("in view"), "{kind:?}: {reason}");
        }
    }
}
