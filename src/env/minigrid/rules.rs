//! The `step` overrides of MiniGrid's environments: what each adds to `MiniGridEnv.step`
//! (the goal's reward and lava's end, which every one keeps).

use serde::{Deserialize, Serialize};

use crate::env::grid::Pos;
use crate::env::object::{Color, DoorState, ObjectId, ObjectKind};
use crate::env::rng::NumpyRng;
use crate::env::world::{Action, StepOutcome, World};

/// One environment's step rules, with the state its Python class keeps between steps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rules {
    /// `MiniGridEnv.step` alone (Empty, DoorKey, FourRooms, LavaGap, DistShift, Crossing,
    /// MultiRoom, LockedRoom, Playground).
    Plain,
    /// Fetch: any pickup ends the episode, rewarded when it is the named object.
    Fetch {
        /// `targetType`.
        kind: ObjectKind,
        /// `targetColor`.
        color: Color,
    },
    /// GoToDoor, GoToObject: `done` beside the target's cell is rewarded; `toggle` and `done`
    /// end the episode.
    GoToCell {
        /// `target_pos`.
        target: Pos,
    },
    /// PutNear: picking up another object ends it; any drop ends it, rewarded within one
    /// cell (8-neighbourhood) of the target's first position.
    PutNear {
        /// `move_type`.
        kind: ObjectKind,
        /// `moveColor`.
        color: Color,
        /// `target_pos`.
        target: Pos,
    },
    /// RedBlueDoors: opening the blue door after the red one is rewarded; before it, fails.
    RedBlueDoors {
        /// The red door's cell.
        red: Pos,
        /// The blue door's cell.
        blue: Pos,
    },
    /// Memory: `pickup` acts as `toggle`; standing on `success` is rewarded, on `failure`
    /// ends the episode.
    Memory {
        /// `success_pos`.
        success: Pos,
        /// `failure_pos`.
        failure: Pos,
    },
    /// KeyCorridor, UnlockPickup, BlockedUnlockPickup, ObstructedMaze: picking up this object
    /// (by identity) is rewarded.
    Pickup {
        /// `self.obj`.
        target: ObjectId,
    },
    /// Unlock: the `toggle` that leaves this door open is rewarded.
    Unlock {
        /// The door's cell.
        door: Pos,
    },
    /// Dynamic-Obstacles: 3 actions (any other acts as `left`); before the agent acts each
    /// ball moves to a free cell of its 3 × 3 neighbourhood (100 tries, drawn from the env's
    /// stream); `forward` into anything but a goal (read before the balls move) gives −1 and
    /// ends the episode.
    DynamicObstacles {
        /// Each ball's id and `cur_pos`, in placement order.
        obstacles: Vec<(ObjectId, Pos)>,
        /// The env's numpy stream, where generation left it.
        rng: NumpyRng,
    },
}

/// Number of actions of Dynamic-Obstacles' action space (`Discrete(forward + 1)`).
pub const DYNAMIC_ACTIONS: usize = 3;

impl Rules {
    /// The size of the environment's action space.
    pub fn num_actions(&self) -> usize {
        match self {
            Self::DynamicObstacles { .. } => DYNAMIC_ACTIONS,
            _ => Action::COUNT,
        }
    }

    /// The environment's `step`: its own rules around `MiniGridEnv.step` (`world.base_step`).
    pub(crate) fn step(&mut self, world: &mut World, action: Action) -> StepOutcome {
        match self {
            Self::Plain => world.base_step(action),
            Self::Fetch { kind, color } => {
                let mut out = world.base_step(action);
                if let Some(c) = world.carrying {
                    out.terminated = true;
                    out.reward = if c.kind == *kind && c.color == *color {
                        world.success_reward()
                    } else {
                        0.0
                    };
                }
                out
            }
            Self::GoToCell { target } => {
                let mut out = world.base_step(action);
                let (a, t) = (world.agent_pos, *target);
                match action {
                    Action::Toggle => out.terminated = true,
                    Action::Done => {
                        let beside = (a.0 == t.0 && (a.1 - t.1).abs() == 1)
                            || (a.1 == t.1 && (a.0 - t.0).abs() == 1);
                        if beside {
                            out.reward = world.success_reward();
                        }
                        out.terminated = true;
                    }
                    _ => {}
                }
                out
            }
            Self::PutNear {
                kind,
                color,
                target,
            } => {
                let pre = world.carrying;
                let mut out = world.base_step(action);
                let front = world.front_pos();
                if action == Action::Pickup
                    && let Some(c) = world.carrying
                    && (c.kind != *kind || c.color != *color)
                {
                    out.terminated = true;
                }
                if action == Action::Drop
                    && let Some(p) = pre
                {
                    let dropped = world.grid.get(front).is_some_and(|o| o.id == p.id);
                    if dropped && (front.0 - target.0).abs() <= 1 && (front.1 - target.1).abs() <= 1
                    {
                        out.reward = world.success_reward();
                    }
                    out.terminated = true;
                }
                out
            }
            Self::RedBlueDoors { red, blue } => {
                let open = |w: &World, p: Pos| {
                    w.grid
                        .get(p)
                        .is_some_and(|d| d.kind == ObjectKind::Door && d.state == DoorState::Open)
                };
                let (red_before, blue_before) = (open(world, *red), open(world, *blue));
                let mut out = world.base_step(action);
                let (red_after, blue_after) = (open(world, *red), open(world, *blue));
                if blue_after {
                    out.terminated = true;
                    out.reward = if red_before {
                        world.success_reward()
                    } else {
                        0.0
                    };
                } else if red_after && blue_before {
                    out.terminated = true;
                    out.reward = 0.0;
                }
                out
            }
            Self::Memory { success, failure } => {
                let action = if action == Action::Pickup {
                    Action::Toggle
                } else {
                    action
                };
                let mut out = world.base_step(action);
                if world.agent_pos == *success {
                    out.reward = world.success_reward();
                    out.terminated = true;
                }
                if world.agent_pos == *failure {
                    out.reward = 0.0;
                    out.terminated = true;
                }
                out
            }
            Self::Pickup { target } => {
                let mut out = world.base_step(action);
                if action == Action::Pickup && world.carrying.is_some_and(|c| c.id == *target) {
                    out.reward = world.success_reward();
                    out.terminated = true;
                }
                out
            }
            Self::Unlock { door } => {
                let mut out = world.base_step(action);
                let open = world
                    .grid
                    .get(*door)
                    .is_some_and(|d| d.state == DoorState::Open);
                if action == Action::Toggle && open {
                    out.reward = world.success_reward();
                    out.terminated = true;
                }
                out
            }
            Self::DynamicObstacles { obstacles, rng } => {
                let action = if (action as usize) < DYNAMIC_ACTIONS {
                    action
                } else {
                    Action::Left
                };
                let front = world.front_pos();
                let not_clear = world
                    .grid
                    .get(front)
                    .is_some_and(|c| c.kind != ObjectKind::Goal);
                for (id, pos) in obstacles.iter_mut() {
                    if let Some(to) = move_ball(world, rng, *id, *pos) {
                        *pos = to;
                    }
                }
                let mut out = world.base_step(action);
                if action == Action::Forward && not_clear {
                    out.reward = -1.0;
                    out.terminated = true;
                }
                out
            }
        }
    }
}

/// One ball of Dynamic-Obstacles: `place_obj(ball, top=old - (1, 1), size=(3, 3),
/// max_tries=100)`, then its old cell emptied; on `RecursionError` it stays (Python swallows
/// the exception, having drawn 101 cells).
fn move_ball(world: &mut World, rng: &mut NumpyRng, id: ObjectId, old: Pos) -> Option<Pos> {
    let ball = world.grid.get(old).filter(|o| o.id == id)?;
    let top = ((old.0 - 1).max(0), (old.1 - 1).max(0));
    let (w, h) = (world.grid.width() as i64, world.grid.height() as i64);
    let (x_hi, y_hi) = ((i64::from(top.0) + 3).min(w), (i64::from(top.1) + 3).min(h));
    for _ in 0..=100 {
        let x = rng.integers(i64::from(top.0), x_hi) as i32;
        let y = rng.integers(i64::from(top.1), y_hi) as i32;
        if world.grid.get((x, y)).is_some() || (x, y) == world.agent_pos {
            continue;
        }
        world.grid.set((x, y), Some(ball));
        world.grid.set(old, None);
        return Some((x, y));
    }
    None
}
