//! The world's unit tests.

use super::*;
use crate::env::mission::{ObjDesc, TaskKind};
use crate::env::object::Color;

/// A 5×5 room, agent at (1, 2) facing right, a red ball at (2, 2) and a blue key at (3, 1).
fn room(task: TaskKind, done_actions: bool) -> World {
    let mut grid = Grid::new(5, 5);
    let mut id = 0;
    grid.wall_ring(&mut id);
    grid.set(
        (2, 2),
        Some(WorldObj::new(ObjectKind::Ball, Color::Red, 100)),
    );
    grid.set(
        (3, 1),
        Some(WorldObj::new(ObjectKind::Key, Color::Blue, 101)),
    );
    let instr = Instruction {
        task,
        desc: ObjDesc {
            kind: Some(ObjectKind::Key),
            color: Some(Color::Blue),
            loc: None,
        },
        fixed: None,
        strict: false,
    };
    World::new(grid, (1, 2), 0, None, instr, 25, done_actions, 200).unwrap()
}

#[test]
fn forward_into_an_object_is_blocked_but_consumes_a_step() {
    let mut w = room(TaskKind::GoTo, false);
    let out = w.step(Action::Forward).unwrap();
    assert_eq!((w.agent_pos, w.step_count, out.reward), ((1, 2), 1, 0.0));
}

#[test]
fn drop_onto_a_non_empty_cell_does_nothing() {
    let mut w = room(TaskKind::GoTo, false);
    w.step(Action::Pickup).unwrap();
    assert_eq!(w.carrying.map(|c| c.id), Some(100));
    w.step(Action::Right).unwrap(); // face (1, 3): empty
    w.step(Action::Left).unwrap();
    w.step(Action::Left).unwrap(); // face (1, 1): empty
    w.step(Action::Left).unwrap(); // face (0, 2): wall
    w.step(Action::Drop).unwrap();
    assert_eq!(
        w.carrying.map(|c| c.id),
        Some(100),
        "cannot drop onto a wall"
    );
    w.step(Action::Left).unwrap(); // face (1, 3) again: empty
    w.step(Action::Drop).unwrap();
    assert_eq!(w.carrying, None);
    assert_eq!(w.grid.get((1, 3)).map(|o| o.id), Some(100));
}

#[test]
fn turning_to_face_the_target_succeeds_without_done() {
    let mut w = room(TaskKind::GoTo, false);
    w.step(Action::Pickup).unwrap(); // clear the ball (a wrong pickup is harmless)
    w.step(Action::Forward).unwrap(); // to (2, 2)
    let out = w.step(Action::Forward).unwrap(); // to (3, 2): facing right, key is up
    assert!(!out.terminated);
    let out = w.step(Action::Left).unwrap(); // face up → (3, 1): the blue key
    assert!(out.terminated && out.reward > 0.0);
    assert_eq!(out.reward, 1.0 - 0.9 * (4.0 / 25.0));
    assert!(w.step(Action::Done).is_err(), "no stepping after the end");
}

#[test]
fn done_mode_needs_done_right_after_a_satisfying_step() {
    let mut w = room(TaskKind::GoTo, true);
    for a in [
        Action::Pickup,
        Action::Forward,
        Action::Forward,
        Action::Left,
    ] {
        assert!(
            !w.step(a).unwrap().terminated,
            "facing the target is not enough"
        );
    }
    let out = w.step(Action::Done).unwrap();
    assert!(out.terminated && out.reward > 0.0);
    // An early done fails with reward 0.
    let mut w = room(TaskKind::GoTo, true);
    let out = w.step(Action::Done).unwrap();
    assert!(out.terminated && out.reward == 0.0);
}

#[test]
fn pickup_needs_the_target_object_and_box_toggle_deletes_it() {
    let mut w = room(TaskKind::Pickup, false);
    assert!(
        !w.step(Action::Pickup).unwrap().terminated,
        "the ball is not the target"
    );
    w.step(Action::Forward).unwrap();
    w.step(Action::Forward).unwrap();
    w.step(Action::Left).unwrap();
    assert!(
        !w.step(Action::Pickup).unwrap().terminated,
        "hands full: the key stays"
    );
    w.step(Action::Right).unwrap();
    w.step(Action::Drop).unwrap(); // ball onto (4, 2)? wall: nothing
    w.step(Action::Right).unwrap(); // face (3, 3): empty
    w.step(Action::Drop).unwrap();
    w.step(Action::Left).unwrap();
    w.step(Action::Left).unwrap(); // face the key
    let out = w.step(Action::Pickup).unwrap();
    assert!(out.terminated && out.reward > 0.0);

    let mut grid = Grid::new(5, 5);
    let mut id = 0;
    grid.wall_ring(&mut id);
    grid.set(
        (2, 2),
        Some(WorldObj::new(ObjectKind::Box, Color::Green, 50)),
    );
    let instr = Instruction {
        task: TaskKind::Pickup,
        desc: ObjDesc {
            kind: Some(ObjectKind::Box),
            color: None,
            loc: None,
        },
        fixed: None,
        strict: false,
    };
    let mut w = World::new(grid, (1, 2), 0, None, instr, 25, false, 60).unwrap();
    w.step(Action::Toggle).unwrap();
    assert_eq!(w.grid.get((2, 2)), None, "toggling a box deletes it");
}
