//! What each word of a MiniGrid mission names: its class and, at a step, the view cells of
//! what it names — the metrics' referents on MiniGrid's own environments, whose missions are
//! not BabyAI instructions (docs/evaluation.md, "MiniGrid's words").
//!
//! - "key", "ball", "box": the visible objects of that type; Memory's "object" (of "the
//!   matching object") the end object that matches the start room's.
//! - "door": the visible doors. "goal": the visible goal cells. "lava": the visible lava.
//! - "opening" (SimpleCrossing, LavaGap with walls): the gap of each wall river in view.
//! - a colour: the visible keys, balls, boxes, doors and goals of that colour ("green" of
//!   "the green goal square"; LockedRoom's rooms are named by their doors' colours).
//!
//! PutNear's and LockedRoom's two phrases and RedBlueDoors' two clauses are told apart: a word
//! after "near" belongs to PutNear's second description, one after "then" to RedBlueDoors'
//! second clause.

use super::Rules;
use crate::env::grid::Pos;
use crate::env::object::{Color, ObjectKind};
use crate::env::roles::{DescPart, WordClass, WordRole};
use crate::env::targets::{
    WordKind, WordTargets, visible_cells_where, visible_objects, visible_world_cells,
};
use crate::env::view::{Observation, ViewCell};
use crate::env::vocab::split_words;
use crate::env::world::World;

/// The role of every word of a MiniGrid mission, in BabyAI's split.
pub fn mission_roles(mission: &str) -> Vec<WordRole> {
    let (mut clause, mut part) = (0, DescPart::Desc);
    split_words(mission)
        .iter()
        .map(|w| {
            let class = match w.as_str() {
                "key" | "ball" | "box" | "object" => WordClass::Object,
                "door" => WordClass::Door,
                "goal" => WordClass::Goal,
                "lava" => WordClass::Lava,
                "opening" => WordClass::Opening,
                c if Color::from_name(c).is_some() => WordClass::Color,
                _ => WordClass::Other,
            };
            let role = WordRole {
                class,
                clause: Some(clause),
                desc: (class != WordClass::Other).then_some(part),
            };
            match w.as_str() {
                "near" => part = DescPart::Fixed,
                "then" => clause += 1,
                _ => {}
            }
            role
        })
        .collect()
}

/// The cells each scored word of a MiniGrid world's mission names at this step.
pub fn word_targets(world: &World, obs: &Observation, n_words: usize) -> Vec<WordTargets> {
    let words = split_words(&world.mission);
    let roles = mission_roles(&world.mission);
    if roles.len() != n_words {
        return Vec::new();
    }
    let mut out = Vec::new();
    for (i, (word, role)) in words.iter().zip(&roles).enumerate() {
        let (kind, cells) = match role.class {
            WordClass::Object if word == "object" => (WordKind::Object, matching_end(world, obs)),
            WordClass::Object => {
                let Some(k) = ObjectKind::from_name(word) else {
                    continue;
                };
                (WordKind::Object, visible_objects(obs, |kind, _| kind == k))
            }
            WordClass::Door => (
                WordKind::Door,
                visible_objects(obs, |k, _| k == ObjectKind::Door),
            ),
            WordClass::Color => {
                let Some(c) = Color::from_name(word) else {
                    continue;
                };
                (WordKind::Color, coloured(obs, c))
            }
            WordClass::Goal => (WordKind::Goal, cells_of_kind(obs, ObjectKind::Goal)),
            WordClass::Lava => (WordKind::Lava, cells_of_kind(obs, ObjectKind::Lava)),
            WordClass::Opening => (
                WordKind::Opening,
                visible_world_cells(world, obs, openings(world)),
            ),
            WordClass::Location | WordClass::Other => continue,
        };
        out.push(WordTargets {
            word: i,
            kind,
            cells,
            region: None,
        });
    }
    out
}

/// The visible cells (not the agent's own) whose encoding is `kind`.
fn cells_of_kind(obs: &Observation, kind: ObjectKind) -> Vec<ViewCell> {
    visible_cells_where(obs, |k, _| k == kind)
}

/// Visible keys, balls, boxes, doors and goals of colour `c`.
fn coloured(obs: &Observation, c: Color) -> Vec<ViewCell> {
    visible_cells_where(obs, |k, col| {
        col == c && (k.can_pickup() || matches!(k, ObjectKind::Door | ObjectKind::Goal))
    })
}

/// The gaps of the wall (or lava) rivers: an interior row or column all obstacle but one cell,
/// that cell (a river crossed once; the rooms between rivers have many free cells).
fn openings(world: &World) -> Vec<Pos> {
    let (w, h) = (world.grid.width() as i32, world.grid.height() as i32);
    let blocked = |p: Pos| {
        world
            .grid
            .get(p)
            .is_some_and(|o| matches!(o.kind, ObjectKind::Wall | ObjectKind::Lava))
    };
    let mut out = Vec::new();
    let mut line = |cells: Vec<Pos>| {
        let free: Vec<Pos> = cells.into_iter().filter(|&p| !blocked(p)).collect();
        if let [gap] = free[..] {
            out.push(gap);
        }
    };
    for y in 1..h - 1 {
        line((1..w - 1).map(|x| (x, y)).collect());
    }
    for x in 1..w - 1 {
        line((1..h - 1).map(|y| (x, y)).collect());
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Memory's matching end object: the object beside the success cell, where visible.
fn matching_end(world: &World, obs: &Observation) -> Vec<ViewCell> {
    let Some(Rules::Memory { success, .. }) = &world.rules else {
        return Vec::new();
    };
    let beside = [(success.0, success.1 - 1), (success.0, success.1 + 1)];
    let cells = beside
        .into_iter()
        .filter(|&p| world.grid.get(p).is_some_and(|o| o.kind.can_pickup()));
    visible_world_cells(world, obs, cells)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::{LevelConfig, LevelId};

    fn world(id: &str, seed: u64) -> World {
        LevelConfig::babyai(LevelId::parse(id).unwrap(), false)
            .generate(seed)
            .unwrap()
    }

    #[test]
    fn putnear_and_redbluedoors_tell_their_two_phrases_apart() {
        let r = mission_roles("put the red key near the blue ball");
        let classes: Vec<_> = r.iter().map(|r| (r.class, r.desc)).collect();
        assert_eq!(classes[2], (WordClass::Color, Some(DescPart::Desc)));
        assert_eq!(classes[3], (WordClass::Object, Some(DescPart::Desc)));
        assert_eq!(classes[6], (WordClass::Color, Some(DescPart::Fixed)));
        assert_eq!(classes[7], (WordClass::Object, Some(DescPart::Fixed)));
        let r = mission_roles("open the red door then the blue door");
        assert_eq!((r[3].class, r[3].clause), (WordClass::Door, Some(0)));
        assert_eq!((r[7].class, r[7].clause), (WordClass::Door, Some(1)));
    }

    #[test]
    fn goal_lava_and_opening_name_their_cells() {
        // LavaGap's agent at (1, 1) facing right sees the lava column and, in the 5×5, the goal.
        let w = world("MiniGrid-LavaGapS5-v0", 0);
        let obs = w.observe();
        let n = split_words(&w.mission).len();
        let t = word_targets(&w, &obs, n);
        let lava = t.iter().find(|t| t.kind == WordKind::Lava).unwrap();
        assert!(!lava.cells.is_empty());
        for c in &lava.cells {
            assert_eq!(obs.at(*c)[0], ObjectKind::Lava as u8);
        }
        // Every SimpleCrossing river has exactly one opening, and it is free.
        let w = world("MiniGrid-SimpleCrossingS9N2-v0", 3);
        let gaps = openings(&w);
        assert_eq!(gaps.len(), 2, "{gaps:?}");
        assert!(gaps.iter().all(|&p| w.grid.get(p).is_none()));
        // Memory's "object" is the end object of the start object's type.
        for seed in 0..20 {
            let w = world("MiniGrid-MemoryS7-v0", seed);
            let Some(Rules::Memory { success, .. }) = &w.rules else {
                panic!()
            };
            let start = w
                .grid
                .get((1, w.grid.height() as i32 / 2 - 1))
                .unwrap()
                .kind;
            let end = [(success.0, success.1 - 1), (success.0, success.1 + 1)]
                .into_iter()
                .find_map(|p| w.grid.get(p))
                .unwrap();
            assert_eq!(end.kind, start, "seed {seed}");
        }
    }
}
