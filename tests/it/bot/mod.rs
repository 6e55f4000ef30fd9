//! minigrid's bot: ours against minigrid's action for action (`minigrid`), as an agent and
//! the expert beside any agent (`expert`), and on MiniGrid's own environments rewarded for one
//! pickup (`pickup`).

mod expert;
mod minigrid;
mod pickup;
