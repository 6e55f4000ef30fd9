//! Recordings: `.rrd` and MCAP read back (`read_back`), the layout of a `.rrd` (`layout`), the
//! instruction tree of BabyAI levels (`levels`), and hostile destinations and interruptions
//! (`destinations`).

mod destinations;
mod layout;
mod levels;
mod read_back;
