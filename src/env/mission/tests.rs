//! The missions' unit tests.

use super::*;

/// Matching among the objects gathered once gives what the full scan gives (and asking
/// whether any matches agrees with both), for every
/// description (no type and walls included, which must fall back to the scan) on big
/// multi-room grids, at every agent direction.
#[test]
fn matching_among_gathered_objects_is_the_full_scan() {
    use crate::env::level::{LevelConfig, LevelId};
    let level = LevelConfig::babyai(LevelId::parse("BabyAI-BossLevel-v0").unwrap(), false);
    let kinds = std::iter::once(None).chain(ObjectKind::ALL.into_iter().map(Some));
    let kinds: Vec<_> = kinds.collect();
    let colors: Vec<_> = std::iter::once(None)
        .chain(Color::ALL.into_iter().map(Some))
        .collect();
    let locs = [
        None,
        Some(Loc::Left),
        Some(Loc::Right),
        Some(Loc::Front),
        Some(Loc::Behind),
    ];
    let mut matched = 0;
    for seed in 0..4 {
        let w = level.generate(seed).unwrap();
        let objects = w.grid.objects_but_walls();
        // The column-by-column gathering is the scan order of `objects`, walls left out.
        let scanned: Vec<_> = w
            .grid
            .objects()
            .filter(|(_, o)| o.kind != ObjectKind::Wall)
            .collect();
        assert_eq!(objects, scanned, "seed {seed}");
        for dir in 0..4 {
            for &kind in &kinds {
                for &color in &colors {
                    for &loc in &locs {
                        let d = ObjDesc { kind, color, loc };
                        let full = d.find_matching(&w.grid, w.rooms, w.agent_pos, dir);
                        let among =
                            d.find_matching_among(&objects, &w.grid, w.rooms, w.agent_pos, dir);
                        assert_eq!(full, among, "{d:?} seed {seed} dir {dir}");
                        matched += full.0.len();
                        // Asking whether any matches, anywhere or in the agent's column
                        // only, answers as the gathered positions do.
                        let (rooms, at) = (w.rooms, w.agent_pos);
                        let any = |keep: fn(Pos, Pos) -> bool| {
                            let found = full.1.iter().any(|&p| keep(p, at));
                            let asked =
                                d.any_matching_among(&objects, &w.grid, rooms, at, dir, |p| {
                                    keep(p, at)
                                });
                            assert_eq!(asked, found, "{d:?} seed {seed} dir {dir}");
                        };
                        any(|_, _| true);
                        any(|p, a| p.0 == a.0);
                    }
                }
            }
        }
    }
    assert!(
        matched > 1000,
        "only {matched} matches: the grids hold too few objects"
    );
}

#[test]
fn surface_text_is_babyai_s() {
    let desc = ObjDesc {
        kind: Some(ObjectKind::Key),
        color: Some(Color::Red),
        loc: None,
    };
    let goto = Instruction {
        task: TaskKind::GoTo,
        desc,
        fixed: None,
        strict: false,
    };
    assert_eq!(goto.surface(1), "go to the red key");
    assert_eq!(goto.surface(2), "go to a red key");
    let pick = Instruction {
        task: TaskKind::Pickup,
        desc: ObjDesc {
            kind: None,
            color: Some(Color::Blue),
            loc: Some(Loc::Left),
        },
        fixed: None,
        strict: false,
    };
    assert_eq!(pick.surface(3), "pick up a blue object on your left");
    let ball = ObjDesc {
        kind: Some(ObjectKind::Ball),
        color: None,
        loc: Some(Loc::Front),
    };
    assert_eq!(ball.surface(1), "the ball in front of you");
}

#[test]
fn parse_reads_back_every_surface_form() {
    for text in [
        "go to the red key",
        "pick up a box",
        "go to the ball",
        "pick up the blue object on your left",
        "go to a key behind you",
    ] {
        let i = Instruction::parse(text).unwrap();
        let n = if text.contains(" a ") { 2 } else { 1 };
        assert_eq!(i.surface(n), text);
    }
    assert!(
        Instruction::parse("go to red key")
            .unwrap_err()
            .to_string()
            .contains("article")
    );
    assert!(
        Instruction::parse("go to the pink key")
            .unwrap_err()
            .to_string()
            .contains("pink")
    );
    assert!(Instruction::parse("to the red key").is_err());
    assert!(Instruction::parse("go to the red").is_err());
}
