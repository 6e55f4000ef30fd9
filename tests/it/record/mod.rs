//! Recordings: `.rrd` and MCAP read back (`read_back`), the layout of a `.rrd` (`layout`), the
//! instruction tree of BabyAI levels (`levels`), MiniGrid's own environments — moving
//! obstacles, agents of three actions, the cells "goal", "lava" and "key" name (`minigrid`) —
//! hostile destinations and interruptions (`destinations`), and the HTML episode page and
//! report as files (`html`) and in a real headless browser (`browser`).

mod browser;
mod destinations;
mod html;
mod layout;
mod levels;
mod minigrid;
mod read_back;
