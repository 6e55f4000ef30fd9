//! minigrid's bot: ours against minigrid's action for action (`minigrid`), and as an agent and
//! the expert beside any agent (`expert`).

mod expert;
mod minigrid;
