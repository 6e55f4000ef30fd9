//! Recordings: `.rrd` and MCAP read back (`read_back`), the layout of a `.rrd` (`layout`), the
//! instruction tree of BabyAI levels (`levels`), MiniGrid's own environments — moving
//! obstacles, agents of three actions, the cells "goal", "lava" and "key" name (`minigrid`) —
//! and hostile destinations and interruptions (`destinations`).

mod destinations;
mod layout;
mod levels;
mod minigrid;
mod read_back;
