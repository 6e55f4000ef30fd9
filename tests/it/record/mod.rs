//! Recordings: `.rrd` and MCAP read back (`read_back`), the layout of a `.rrd` (`layout`), the
//! instruction tree of BabyAI levels (`levels`), hostile destinations and interruptions
//! (`destinations`), and the HTML episode page and report as files (`html`) and in a real
//! headless browser (`browser`).

mod browser;
mod destinations;
mod html;
mod layout;
mod levels;
mod read_back;
