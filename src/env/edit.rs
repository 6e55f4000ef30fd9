//! Probing edits: change a world mid-episode (the mission, the objects, the agent) and get a
//! consistent world back, or a reason why the edit is refused. The debugger re-runs the
//! policy from the result.
//!
//! An edited world keeps its step count (so rewards stay comparable) and re-resolves the
//! instruction's targets on the edited grid, as BabyAI does at reset.

use super::error::EnvError;
use super::grid::Pos;
use super::instr::parse_mission;
use super::object::{Color, ObjectKind, WorldObj};
use super::world::World;

/// One change to a world.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Edit {
    /// Replace the mission (vocabulary words only; it must name an object of the world).
    Mission(String),
    /// Put the agent on another free cell.
    MoveAgent(Pos),
    /// Turn the agent to face `0` right, `1` down, `2` left, `3` up.
    TurnAgent(u8),
    /// Remove the object at a cell.
    Remove(Pos),
    /// Add an object on an empty cell.
    Add(Pos, ObjectKind, Color),
    /// Change the colour of the object at a cell.
    Recolor(Pos, Color),
    /// Move the object at the first cell to the second (which must be empty).
    MoveObject(Pos, Pos),
}

fn refuse(field: &str, reason: impl Into<String>) -> EnvError {
    EnvError::InvalidState {
        field: field.into(),
        reason: reason.into(),
    }
}

/// The object at `pos` that edits may change: keys, balls and boxes.
fn movable(world: &World, pos: Pos) -> Result<WorldObj, EnvError> {
    match world.grid.get_or_wall(pos) {
        Some(obj) if obj.kind.can_pickup() => Ok(obj),
        Some(obj) => Err(refuse(
            "cell",
            format!("{pos:?} holds a {}, which cannot be edited", obj.kind),
        )),
        None => Err(refuse("cell", format!("{pos:?} is empty"))),
    }
}

/// Checks that an object may be placed on `pos`: inside the grid, empty, not the agent.
fn free_for_object(world: &World, pos: Pos) -> Result<(), EnvError> {
    if !world.grid.contains(pos) {
        return Err(refuse("cell", format!("{pos:?} is outside the grid")));
    }
    if let Some(obj) = world.grid.get(pos) {
        return Err(refuse(
            "cell",
            format!("{pos:?} already holds a {}", obj.describe()),
        ));
    }
    if pos == world.agent_pos {
        return Err(refuse("cell", format!("{pos:?} is the agent's cell")));
    }
    Ok(())
}

/// Applies `edit` to a copy of `world`. Refused edits (two objects in one cell, the agent in a
/// wall or on an object, a mission no object matches, an unknown word) return the reason and
/// leave nothing changed.
pub fn apply(world: &World, edit: &Edit) -> Result<World, EnvError> {
    if world.ended() {
        return Err(refuse("world", "the episode has ended"));
    }
    let mut grid = world.grid.clone();
    let (mut pos, mut dir) = (world.agent_pos, world.agent_dir);
    let mut instr = world.instr.clone();
    let mut next_id = world.next_id;
    match edit {
        Edit::Mission(text) => instr = parse_mission(text)?,
        Edit::MoveAgent(to) => {
            if !grid.contains(*to) {
                return Err(refuse("agent_pos", format!("{to:?} is outside the grid")));
            }
            if let Some(obj) = grid.get(*to) {
                return Err(refuse(
                    "agent_pos",
                    format!(
                        "{to:?} holds a {}; the agent cannot stand there",
                        obj.describe()
                    ),
                ));
            }
            pos = *to;
        }
        Edit::TurnAgent(d) => {
            if *d > 3 {
                return Err(refuse(
                    "agent_dir",
                    format!("{d} is not a direction (0..=3)"),
                ));
            }
            dir = *d;
        }
        Edit::Remove(at) => {
            movable(world, *at)?;
            grid.set(*at, None);
        }
        Edit::Add(at, kind, color) => {
            if !kind.can_pickup() {
                return Err(refuse(
                    "kind",
                    format!("only keys, balls and boxes can be added, not a {kind}"),
                ));
            }
            free_for_object(world, *at)?;
            grid.set(*at, Some(WorldObj::new(*kind, *color, next_id)));
            next_id += 1;
        }
        Edit::Recolor(at, color) => {
            let mut obj = movable(world, *at)?;
            obj.color = *color;
            grid.set(*at, Some(obj));
        }
        Edit::MoveObject(from, to) => {
            let obj = movable(world, *from)?;
            free_for_object(world, *to)?;
            grid.set(*from, None);
            grid.set(*to, Some(obj));
        }
    }
    let mut edited = World::with_tree(
        grid,
        world.rooms,
        pos,
        dir,
        world.carrying,
        instr,
        world.max_steps,
        world.done_actions,
        next_id,
    )?;
    edited.step_count = world.step_count;
    edited.box_contents.clone_from(&world.box_contents);
    edited.moved.clone_from(&world.moved);
    Ok(edited)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::level::LevelConfig;

    fn world() -> World {
        LevelConfig::default().generate(3).unwrap()
    }

    fn empty_cell(w: &World) -> Pos {
        (1..w.grid.width() as i32 - 1)
            .flat_map(|x| (1..w.grid.height() as i32 - 1).map(move |y| (x, y)))
            .find(|&p| w.grid.get(p).is_none() && p != w.agent_pos)
            .unwrap()
    }

    #[test]
    fn objects_can_be_added_moved_recoloured_and_removed() {
        let w = world();
        let at = empty_cell(&w);
        let added = apply(&w, &Edit::Add(at, ObjectKind::Ball, Color::Purple)).unwrap();
        let obj = added.grid.get(at).unwrap();
        assert_eq!((obj.kind, obj.color), (ObjectKind::Ball, Color::Purple));
        assert_eq!(added.step_count, w.step_count);
        let recoloured = apply(&added, &Edit::Recolor(at, Color::Red)).unwrap();
        assert_eq!(recoloured.grid.get(at).unwrap().color, Color::Red);
        let to = empty_cell(&recoloured);
        let moved = apply(&recoloured, &Edit::MoveObject(at, to)).unwrap();
        assert!(moved.grid.get(at).is_none());
        assert_eq!(moved.grid.get(to).unwrap().id, obj.id);
        let removed = apply(&moved, &Edit::Remove(to)).unwrap();
        assert!(removed.grid.get(to).is_none());
    }

    #[test]
    fn invalid_edits_are_refused_with_a_reason() {
        let w = world();
        let (obj_pos, _) = w.grid.objects().find(|(_, o)| o.kind.can_pickup()).unwrap();
        let err = apply(&w, &Edit::Add(obj_pos, ObjectKind::Key, Color::Red)).unwrap_err();
        assert!(err.to_string().contains("already holds"), "{err}");
        let err = apply(&w, &Edit::MoveAgent((0, 0))).unwrap_err();
        assert!(err.to_string().contains("wall"), "{err}");
        let err = apply(&w, &Edit::MoveAgent(obj_pos)).unwrap_err();
        assert!(err.to_string().contains("cannot stand"), "{err}");
        let err = apply(&w, &Edit::Add(w.agent_pos, ObjectKind::Key, Color::Red)).unwrap_err();
        assert!(err.to_string().contains("agent"), "{err}");
        let err = apply(&w, &Edit::Remove((0, 0))).unwrap_err();
        assert!(err.to_string().contains("cannot be edited"), "{err}");
        let err = apply(&w, &Edit::Mission("go to the pink key".into())).unwrap_err();
        assert!(err.to_string().contains("pink"), "{err}");
        assert!(apply(&w, &Edit::TurnAgent(4)).is_err());
    }

    #[test]
    fn the_mission_and_the_pose_can_change() {
        let w = world();
        let at = empty_cell(&w);
        let moved = apply(&w, &Edit::MoveAgent(at)).unwrap();
        assert_eq!(moved.agent_pos, at);
        let turned = apply(&moved, &Edit::TurnAgent((moved.agent_dir + 1) % 4)).unwrap();
        assert_eq!(turned.agent_dir, (moved.agent_dir + 1) % 4);
        let (_, obj) = w.grid.objects().find(|(_, o)| o.kind.can_pickup()).unwrap();
        let text = format!("pick up the {} {}", obj.color, obj.kind);
        let m = apply(&w, &Edit::Mission(text)).unwrap();
        assert!(m.mission.starts_with("pick up"));
        assert!(m.targets().contains(&obj.id));
    }
}
