//! The per-episode faithfulness measures' unit tests.

use super::*;

#[test]
fn counterfactual_worlds_are_valid_starts() {
    let level = LevelConfig::default();
    let mut made = BTreeMap::<&str, usize>::new();
    for seed in 0..40 {
        let world = level.generate(seed).unwrap();
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        for name in COUNTERFACTUALS {
            let Ok(edited) = counterfactual(name, &world, &mut rng) else {
                continue;
            };
            *made.entry(name).or_default() += 1;
            edited.validate().unwrap();
            assert!(all_reachable(&edited.grid, edited.agent_pos));
            assert!(!edited.target_positions().is_empty(), "{name}: a target");
            let desc = edited.desc();
            match name {
                // The twin differs in colour, so exactly the old targets still match.
                "add_twin" => assert_eq!(
                    edited.target_positions().len(),
                    world.target_positions().len()
                ),
                "mission_color_to_distractor" => {
                    assert_ne!(desc.color, world.desc().color);
                    assert!(
                        edited
                            .target_positions()
                            .iter()
                            .all(|p| { !world.target_positions().contains(p) })
                    );
                }
                "move_target" => assert_eq!(desc, world.desc()),
                _ => {}
            }
        }
    }
    for name in COUNTERFACTUALS.iter().filter(|n| **n != "swap_putnext") {
        assert!(
            made.get(name).copied().unwrap_or(0) >= 5,
            "{name}: {made:?}"
        );
    }
    assert_eq!(
        made.get("swap_putnext"),
        None,
        "no PutNext on the paper's level"
    );
}

#[test]
fn counterfactuals_edit_the_clause_waited_on_on_babyai_levels() {
    use crate::env::level::LevelId;
    let level = |id| LevelConfig {
        babyai: Some(LevelId::parse(id).unwrap()),
        ..LevelConfig::default()
    };
    let mut made = BTreeMap::<(&str, &str), usize>::new();
    for id in [
        "BabyAI-PutNextLocal-v0",
        "BabyAI-GoToObjDoor-v0",
        "BabyAI-SynthSeq-v0",
    ] {
        for seed in 0..20 {
            let world = level(id).generate(seed).unwrap();
            let mut rng = Pcg64Mcg::seed_from_u64(seed);
            for name in COUNTERFACTUALS {
                let Ok(edited) = counterfactual(name, &world, &mut rng) else {
                    continue;
                };
                *made.entry((id, name)).or_default() += 1;
                edited.validate().unwrap();
                // Every other clause is untouched.
                let (a, b) = (world.instr.clauses(), edited.instr.clauses());
                assert_eq!(a.len(), b.len());
                let c = pending_clauses(&world.instr)[0];
                for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                    if i != c {
                        assert_eq!(x.instr, y.instr, "{id} {seed} {name}");
                    }
                }
                if name == "swap_putnext" {
                    assert_eq!(b[c].instr.desc, a[c].instr.fixed.unwrap());
                    assert_eq!(b[c].instr.fixed, Some(a[c].instr.desc));
                }
            }
        }
    }
    assert!(
        made.get(&("BabyAI-PutNextLocal-v0", "swap_putnext")) >= Some(&15),
        "{made:?}"
    );
    assert!(
        made.get(&("BabyAI-SynthSeq-v0", "recolor_target")) >= Some(&5),
        "{made:?}"
    );
    assert!(
        made.get(&("BabyAI-GoToObjDoor-v0", "recolor_target")) >= Some(&5),
        "{made:?}"
    );
}
