//! The instruction verifiers' unit tests.

use super::*;

#[test]
fn missions_parse_into_trees_that_read_back() {
    /// Reads a tree back with the article each description was written with.
    fn surf(t: &Instr, text: &str, out: &mut String) {
        match t {
            Instr::Action(n) => {
                let the = |d: &ObjDesc| {
                    let one = d.surface(1);
                    if text.contains(&one) { 1 } else { 2 }
                };
                let nf = n.instr.fixed.map_or(1, |f| the(&f));
                out.push_str(&n.instr.surface_with(the(&n.instr.desc), nf));
            }
            Instr::Seq(s) => {
                surf(&s.a, text, out);
                out.push_str(s.kind.joiner());
                surf(&s.b, text, out);
            }
        }
    }
    for text in [
        "go to the red ball",
        "open a door on your left",
        "put the blue key next to a box",
        "pick up the ball and go to a grey door",
        "open the red door and go to the box after you pick up a key",
        "go to a key, then pick up the purple box",
        "put a ball next to the green ball after you open the yellow door",
    ] {
        let tree = parse_mission(text).unwrap();
        // Read back with the article each description was written with.
        let mut out = String::new();
        surf(&tree, text, &mut out);
        assert_eq!(out, text);
    }
    assert!(parse_mission("open the red key").is_err());
    assert!(parse_mission("pick up the door").is_err());
    assert!(parse_mission("put the ball").is_err());
}

#[test]
fn a_mission_error_names_the_word_and_its_position() {
    let reason = |text: &str| match parse_mission(text) {
        Err(EnvError::InvalidMission { reason, .. }) => reason,
        other => panic!("{text}: {other:?}"),
    };
    for (text, want) in [
        (
            "go to the red ball please",
            "word 6 \"please\": unexpected after the object",
        ),
        (
            "go to the red ball go to the box",
            "word 6 \"go\": unexpected after the object",
        ),
        ("go to the ball on your lft", "word 7 \"lft\": unexpected"),
        (
            "go to the ball on your",
            "after word 6 \"your\", the last: the location is unfinished",
        ),
        ("go to red ball", "word 3 \"red\": an article"),
        (
            "go the red ball",
            "word 2 \"the\": \"go\" must be followed by \"to\"",
        ),
        (
            "walk to the red ball",
            "word 1 \"walk\": a clause must start with",
        ),
        (
            "go to the red ball and",
            "after word 6 \"and\", the last: a clause",
        ),
        ("and go to the red ball", "before word 1 \"and\": a clause"),
        (
            "pick up the key, then go to the red lamp",
            "word 10 \"lamp\": not key, ball, box, door",
        ),
        (
            "go to the box after you open the red",
            "after word 9 \"red\", the last: it names no object",
        ),
        (
            "open the box and pick up the key",
            "word 3 \"box\": only a door can be opened",
        ),
        (
            "go to a key and pick up the grey door",
            "word 10 \"door\": a door cannot be picked up",
        ),
        (
            "put the door next to a key",
            "word 3 \"door\": a door cannot be put",
        ),
        (
            "put the key next to the",
            "after word 6 \"the\", the last: it names no object",
        ),
        (
            "put the key near the box",
            "word 1 \"put\": needs \"next to\"",
        ),
        ("", "the mission has no words"),
    ] {
        let got = reason(text);
        assert!(got.starts_with(want), "{text:?}: {got}");
    }
}
