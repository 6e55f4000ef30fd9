//! MiniGrid's own failures, in its terms ([`FailureClass::MINIGRID`]): how the episode ended —
//! in lava, against an obstacle, on the wrong pickup, the blue door first, a drop away from the
//! target, at the wrong end of Memory's hallway — and, for an episode that ended otherwise, how
//! far it got along its level's chain — the box holding the key, the key, the locked door, the
//! rooms beyond — each with the step where it was lost. Read from the steps alone (the world
//! before each action, the action, its reward and end), on worlds with MiniGrid's step rules
//! ([`World::rules`]); on BabyAI's levels nothing here fires.
//!
//! The chain, set up at the first step from the world as generated:
//! - the *locked doors the level needs*: on a RoomGrid level (KeyCorridor, UnlockPickup,
//!   BlockedUnlockPickup, ObstructedMaze) the locked doors in the walls of the room holding
//!   the object to pick up; Unlock's door; on a one-room layout (DoorKey, LockedRoom) every
//!   locked door;
//! - their *keys*: the keys of those doors' colours, on the floor or in a box, and the boxes
//!   holding them (ObstructedMaze's key-in-box presets);
//! - the *rooms*: on a RoomGrid level the room holding the object to pick up (a doorway counts
//!   as inside, as on BabyAI); on a one-room layout the cells of the locked doors, or on a
//!   level with a goal, doors and no locked door (MultiRoom) every door: a room behind a door
//!   the agent never stood on was never entered.
//!
//! Where a chain class was lost ([`Link::chance`], [`Link::seen`]): the first step at which
//! the agent passed up its chance — the key in front and no `pickup`, the box in front and no
//! `toggle`, the locked door in front with its key in hand and no `toggle`, the door to the
//! room in front, open or openable (closed, or locked with its key in hand), and neither a
//! `forward` through it nor a `toggle` that opens it — else the last step at which the object
//! was in view, else none (the decisive step then falls back as on BabyAI).

use super::mechanics::rooms_at;
use super::{FailureClass, StepFacts};
use crate::env::grid::Pos;
use crate::env::minigrid::{Class, Rules};
use crate::env::object::{Color, DoorState, ObjectId, ObjectKind, WorldObj};
use crate::env::view::{AGENT_IN_VIEW, Observation, view_from_world};
use crate::env::world::{Action, World};

/// A room `(i, j)` of the level's room grid.
type Room = (i32, i32);

/// One object of the level's chain, followed over the episode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// The object (a boxed key: the key's own id).
    pub id: ObjectId,
    /// Its cell at the first step (a boxed key: its box's).
    pub pos: Pos,
    /// Its colour.
    pub color: Color,
    /// Done: the box opened, a key of its colour carried, the door open, the door stood on.
    pub done: bool,
    /// The first step at which the agent passed up its chance at it, while not done.
    pub chance: Option<u32>,
    /// The last step at which it was in the agent's view, while not done.
    pub seen: Option<u32>,
}

impl Link {
    fn new(pos: Pos, o: WorldObj) -> Self {
        Self {
            id: o.id,
            pos,
            color: o.color,
            done: false,
            chance: None,
            seen: None,
        }
    }

    /// Notes step `t`: whether it passed up its chance, whether the object was in view.
    fn note(&mut self, t: u32, passed_up: bool, seen: bool) {
        if self.done {
            return;
        }
        if passed_up && self.chance.is_none() {
            self.chance = Some(t);
        }
        if seen {
            self.seen = Some(t);
        }
    }
}

/// Where a chain class over `links` was lost: the first chance passed up, else the last step
/// one of them was seen.
fn decisive(links: &[Link]) -> Option<u32> {
    links
        .iter()
        .filter_map(|l| l.chance)
        .min()
        .or_else(|| links.iter().filter_map(|l| l.seen).max())
}

/// Whether `pos` is a seen cell of the observation, other than the agent's own.
fn in_view(w: &World, obs: &Observation, pos: Pos) -> bool {
    view_from_world(w.agent_pos, w.agent_dir, pos)
        .is_some_and(|c| c != AGENT_IN_VIEW && obs.visible(c))
}

/// Whether a `toggle` at `door` opens it: closed, or locked with its key in hand.
fn opens(w: &World, door: Option<WorldObj>) -> bool {
    door.is_some_and(|d| {
        d.kind == ObjectKind::Door
            && match d.state {
                DoorState::Closed => true,
                DoorState::Locked => holds_key(w, d.color),
                DoorState::Open => false,
            }
    })
}

/// Whether the agent carries a key of `color`.
fn holds_key(w: &World, color: Color) -> bool {
    w.carrying
        .is_some_and(|o| o.kind == ObjectKind::Key && o.color == color)
}

/// What an episode on one of MiniGrid's environments showed of its own rules.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MiniGridEvidence {
    /// The chain was set up (a step of a MiniGrid world was seen).
    pub started: bool,
    /// How the episode ended, when one of MiniGrid's endings, and the step.
    pub outcome: Option<(FailureClass, u32)>,
    /// The locked doors the level needs.
    pub locked: Vec<Link>,
    /// Their keys (a boxed key at its box's cell).
    pub keys: Vec<Link>,
    /// The boxes holding those keys.
    pub boxes: Vec<Link>,
    /// The doors into the rooms to enter (one-room layouts: done once stood on).
    pub entries: Vec<Link>,
    /// On a RoomGrid level, the rooms holding the object to pick up.
    pub target_rooms: Vec<Room>,
    /// The agent stood in one of [`Self::target_rooms`].
    pub room_entered: bool,
}

impl MiniGridEvidence {
    /// Adds one step (nothing on a world without MiniGrid's rules).
    pub fn push(&mut self, step: &StepFacts<'_>) {
        let w = step.world;
        let Some(rules) = &w.rules else {
            return;
        };
        if !self.started {
            self.started = true;
            self.set_up(w, rules);
        }
        let (t, a) = (w.step_count, step.action);
        let front = w.front_pos();
        let ahead = w.grid.get(front);
        let facing = |id: ObjectId| ahead.is_some_and(|o| o.id == id);
        // Where the action leaves the agent (Dynamic-Obstacles' balls aside).
        let after = if a == Action::Forward && ahead.is_none_or(|o| o.can_overlap()) {
            front
        } else {
            w.agent_pos
        };
        let on_floor = |pos: Pos, id: ObjectId| w.grid.get(pos).is_some_and(|o| o.id == id);
        for l in &mut self.boxes {
            let passed = facing(l.id) && a != Action::Toggle;
            let seen = on_floor(l.pos, l.id) && in_view(w, step.obs, l.pos);
            l.note(t, passed, seen);
            l.done |= facing(l.id) && a == Action::Toggle;
        }
        for l in &mut self.keys {
            let passed = facing(l.id) && a != Action::Pickup;
            let seen = on_floor(l.pos, l.id) && in_view(w, step.obs, l.pos);
            l.note(t, passed, seen);
            let picks = facing(l.id) && a == Action::Pickup && w.carrying.is_none();
            l.done |= picks || holds_key(w, l.color);
        }
        for l in &mut self.locked {
            let door = w.grid.get(l.pos);
            let open = door.is_some_and(|d| d.state == DoorState::Open);
            let here = front == l.pos;
            let passed = !open && here && holds_key(w, l.color) && a != Action::Toggle;
            l.note(t, passed, !open && in_view(w, step.obs, l.pos));
            l.done |= open || (here && a == Action::Toggle && opens(w, door));
        }
        for l in &mut self.entries {
            // A chance only where the door can be walked through or opened now.
            let door = w.grid.get(l.pos);
            let open = door.is_some_and(|d| d.can_overlap());
            let through = a == Action::Forward && open;
            let opened = a == Action::Toggle && opens(w, door);
            let passed = front == l.pos && (open || opens(w, door)) && !through && !opened;
            l.note(t, passed, in_view(w, step.obs, l.pos));
            l.done |= w.agent_pos == l.pos || after == l.pos;
        }
        if !self.room_entered {
            let rooms = w.rooms;
            self.room_entered = self
                .target_rooms
                .iter()
                .any(|&r| rooms.pos_inside(r, w.agent_pos) || rooms.pos_inside(r, after));
        }
        if step.terminated && step.reward <= 0.0 {
            self.outcome = ending(w, rules, a, ahead, after).map(|c| (c, t));
        }
    }

    /// The chain of the world at its first step.
    fn set_up(&mut self, w: &World, rules: &Rules) {
        let objects = w.grid.objects_but_walls();
        let multi = w.rooms.num_cols * w.rooms.num_rows > 1;
        if multi
            && let Rules::Pickup { target } = rules
            && let Some(&(p, _)) = objects.iter().find(|e| e.1.id == *target)
        {
            self.target_rooms = rooms_at(w, p).collect();
        }
        let rooms = self.target_rooms.clone();
        let in_target_room = |p: Pos| rooms_at(w, p).any(|r| rooms.contains(&r));
        let locked: Vec<(Pos, WorldObj)> = objects
            .iter()
            .filter(|e| e.1.kind == ObjectKind::Door && e.1.state == DoorState::Locked)
            .copied()
            .collect();
        let needed: Vec<(Pos, WorldObj)> = match rules {
            Rules::Unlock { door } => locked.iter().filter(|e| e.0 == *door).copied().collect(),
            _ if multi => locked
                .iter()
                .filter(|e| in_target_room(e.0))
                .copied()
                .collect(),
            Rules::Plain => locked,
            _ => Vec::new(),
        };
        self.locked = needed.iter().map(|&(p, o)| Link::new(p, o)).collect();
        let colors: Vec<Color> = needed.iter().map(|e| e.1.color).collect();
        self.keys = objects
            .iter()
            .filter(|e| e.1.kind == ObjectKind::Key && colors.contains(&e.1.color))
            .map(|&(p, o)| Link::new(p, o))
            .collect();
        for (bx, inner) in &w.box_contents {
            if inner.kind == ObjectKind::Key
                && colors.contains(&inner.color)
                && let Some(&(p, b)) = objects.iter().find(|e| e.1.id == *bx)
            {
                self.boxes.push(Link::new(p, b));
                self.keys.push(Link::new(p, *inner));
            }
        }
        let doors = objects.iter().filter(|e| e.1.kind == ObjectKind::Door);
        self.entries = if multi {
            if rooms.is_empty() {
                Vec::new()
            } else {
                doors
                    .filter(|e| in_target_room(e.0))
                    .map(|&(p, o)| Link::new(p, o))
                    .collect()
            }
        } else if !matches!(rules, Rules::Plain) {
            Vec::new()
        } else if !self.locked.is_empty() {
            self.locked.clone()
        } else if objects.iter().any(|e| e.1.kind == ObjectKind::Goal) {
            doors.map(|&(p, o)| Link::new(p, o)).collect()
        } else {
            Vec::new()
        };
    }

    /// The MiniGrid class of a failed episode and where it was lost, if one holds: its ending,
    /// else the first link of its chain it never got past.
    pub fn class(&self) -> Option<(FailureClass, Option<u32>)> {
        if let Some((c, t)) = self.outcome {
            return Some((c, Some(t)));
        }
        if !self.locked.is_empty() && !self.locked.iter().any(|l| l.done) {
            let key_held = self.keys.iter().any(|l| l.done);
            let boxes_shut = !self.boxes.is_empty() && !self.boxes.iter().any(|l| l.done);
            return Some(if key_held {
                (FailureClass::LockedDoorNeverOpened, decisive(&self.locked))
            } else if boxes_shut {
                (FailureClass::BoxNeverOpened, decisive(&self.boxes))
            } else {
                (FailureClass::KeyNeverPickedUp, decisive(&self.keys))
            });
        }
        let missed: Vec<Link> = if self.target_rooms.is_empty() {
            self.entries.iter().filter(|l| !l.done).copied().collect()
        } else if self.room_entered {
            Vec::new()
        } else {
            self.entries.clone()
        };
        let never = if self.target_rooms.is_empty() {
            !missed.is_empty()
        } else {
            !self.room_entered
        };
        never.then(|| (FailureClass::RoomsNeverEntered, decisive(&missed)))
    }
}

/// The MiniGrid ending of a step that ended the episode without reward: the world before it,
/// its action, the cell in front before it, and where it left the agent.
fn ending(
    w: &World,
    rules: &Rules,
    a: Action,
    ahead: Option<WorldObj>,
    after: Pos,
) -> Option<FailureClass> {
    if a == Action::Forward && ahead.is_some_and(|o| o.kind == ObjectKind::Lava) {
        return Some(FailureClass::SteppedIntoLava);
    }
    match rules {
        // The front cell as Dynamic-Obstacles reads it, before its balls move.
        Rules::DynamicObstacles { .. } => (a == Action::Forward
            && ahead.is_some_and(|o| o.kind != ObjectKind::Goal))
        .then_some(FailureClass::HitObstacle),
        Rules::Fetch { kind, color } | Rules::PutNear { kind, color, .. }
            if a == Action::Pickup =>
        {
            ahead
                .filter(|o| o.kind.can_pickup() && w.carrying.is_none())
                .filter(|o| (o.kind, o.color) != (*kind, *color))
                .map(|_| FailureClass::PickedWrongObject)
        }
        Rules::PutNear { .. } if a == Action::Drop && w.carrying.is_some() => {
            Some(FailureClass::DroppedFarFromTarget)
        }
        Rules::RedBlueDoors { red, blue } if a == Action::Toggle && w.front_pos() == *blue => {
            let red_open = w.grid.get(*red).is_some_and(|d| d.state == DoorState::Open);
            (!red_open).then_some(FailureClass::DoorsOutOfOrder)
        }
        Rules::Memory { failure, .. } if after == *failure => Some(FailureClass::WrongEndObject),
        _ => None,
    }
}

/// The MiniGrid classes an episode of `class` can get, in the order they are decided (the
/// zero counts a report's cell of that environment lists).
pub fn classes_of(class: &Class) -> Vec<FailureClass> {
    use FailureClass as F;
    let chain = |boxed: bool, rooms: bool| {
        let mut v = Vec::new();
        if boxed {
            v.push(F::BoxNeverOpened);
        }
        v.extend([F::KeyNeverPickedUp, F::LockedDoorNeverOpened]);
        if rooms {
            v.push(F::RoomsNeverEntered);
        }
        v
    };
    match *class {
        Class::LavaGap { lava: true, .. }
        | Class::Crossing { lava: true, .. }
        | Class::DistShift { .. } => vec![F::SteppedIntoLava],
        Class::DynamicObstacles { .. } => vec![F::HitObstacle],
        Class::Fetch { .. } => vec![F::PickedWrongObject],
        Class::PutNear { .. } => vec![F::PickedWrongObject, F::DroppedFarFromTarget],
        Class::RedBlueDoors { .. } => vec![F::DoorsOutOfOrder],
        Class::Memory { .. } => vec![F::WrongEndObject],
        Class::Unlock => chain(false, false),
        Class::DoorKey { .. }
        | Class::LockedRoom { .. }
        | Class::KeyCorridor { .. }
        | Class::UnlockPickup
        | Class::BlockedUnlockPickup => chain(false, true),
        Class::ObstructedMaze1 { key_in_box, .. }
        | Class::ObstructedMazeFull { key_in_box, .. } => chain(key_in_box, true),
        Class::MultiRoom { .. } => vec![F::RoomsNeverEntered],
        _ => Vec::new(),
    }
}
