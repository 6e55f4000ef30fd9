//! The doors between a generator's rooms: `connect_all`, opening every door, the locked
//! doors' colours.

use super::{Gen, Retry, Slot};
use crate::env::object::{Color, DoorState};

impl Gen {
    /// `connect_all(door_colors)`: doors between random neighbours until every room is
    /// reachable from the agent's room.
    pub fn connect_all(&mut self, door_colors: &[Color]) -> Result<(), Retry> {
        let start = self.room_at(self.agent_pos);
        let total = self.room_list.len();
        let mut itrs = 0u32;
        // The rooms reached change only when a door is added, and then only by what the
        // door's far side reaches: the flood goes on from there (up to 64 rooms; past that
        // the whole fill again).
        let small = total <= 64;
        let mut seen = if small { self.flood(0, start) } else { 0 };
        let mut reached = if small {
            seen.count_ones() as usize
        } else {
            self.reach_large(start)
        };
        loop {
            if itrs > 5000 {
                return Err(Retry::Recursion("connect_all failed"));
            }
            itrs += 1;
            if reached == total {
                return Ok(());
            }
            let i = self.rand_int(0, self.rooms.num_cols);
            let j = self.rand_int(0, self.rooms.num_rows);
            let k = self.rng.below(0, 4);
            let r = self.room_index(i, j);
            let room = &self.room_list[r];
            if room.door_pos[k].is_none() || room.doors[k].connects() {
                continue;
            }
            let Some(n) = room.neighbors[k] else {
                continue;
            };
            if room.locked || self.room_list[n].locked {
                continue;
            }
            let color = self.rand_elem(door_colors);
            self.add_door(i, j, Some(k), Some(color), Some(false));
            if !small {
                reached = self.reach_large(start);
            } else if (seen >> r) & 1 != (seen >> n) & 1 {
                seen = self.flood(seen, if (seen >> r) & 1 == 1 { n } else { r });
                reached = seen.count_ones() as usize;
            }
        }
    }

    /// The rooms in `seen` (a bit mask, at most 64 rooms) with every room `from` reaches
    /// through doors and removed walls without passing a room of `seen`.
    fn flood(&self, seen: u64, from: usize) -> u64 {
        let mut seen = seen | 1 << from;
        let mut frontier = 1u64 << from;
        while frontier != 0 {
            let r = frontier.trailing_zeros() as usize;
            frontier &= frontier - 1;
            let room = &self.room_list[r];
            for k in 0..4 {
                if room.doors[k].connects()
                    && let Some(nb) = room.neighbors[k]
                    && seen & (1 << nb) == 0
                {
                    seen |= 1 << nb;
                    frontier |= 1 << nb;
                }
            }
        }
        seen
    }

    /// How many rooms `start` reaches through doors and removed walls, for more than the 64
    /// rooms [`Self::flood`] holds.
    fn reach_large(&self, start: usize) -> usize {
        let mut seen = vec![false; self.room_list.len()];
        let mut stack = vec![start];
        seen[start] = true;
        let mut n = 0;
        while let Some(r) = stack.pop() {
            n += 1;
            for k in 0..4 {
                if self.room_list[r].doors[k].connects()
                    && let Some(nb) = self.room_list[r].neighbors[k]
                    && !seen[nb]
                {
                    seen[nb] = true;
                    stack.push(nb);
                }
            }
        }
        n
    }

    /// `open_all_doors`: every door of every room open (`is_open = True`).
    pub fn open_all_doors(&mut self) {
        for r in 0..self.room_list.len() {
            for k in 0..4 {
                if let Slot::Door(_, pos) = self.room_list[r].doors[k]
                    && let Some(mut d) = self.grid.get(pos)
                {
                    // A locked door set open would keep `is_locked` in Python; the levels
                    // that open all doors have none.
                    d.state = DoorState::Open;
                    self.grid.set(pos, Some(d));
                }
            }
        }
    }

    /// The colours of the locked doors, room by room (`validate_instrs` with unblocking).
    pub fn locked_door_colors(&self) -> Vec<Color> {
        let mut out = Vec::new();
        for i in 0..self.rooms.num_cols {
            for j in 0..self.rooms.num_rows {
                for slot in self.room_list[self.room_index(i, j)].doors {
                    if let Slot::Door(_, pos) = slot
                        && let Some(d) = self.grid.get(pos)
                        && d.state == DoorState::Locked
                    {
                        out.push(d.color);
                    }
                }
            }
        }
        out
    }
}
