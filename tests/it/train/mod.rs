//! Training: PPO (`ppo`), `train` on the command line (`cli`) and on several levels
//! (`levels`), the run as a core object (`run`), its spec, refusals and a resume's
//! differences (`spec`), imitation of trained teachers (`teacher`), and crash consistency
//! (`crash`).

mod cli;
mod crash;
mod levels;
mod ppo;
mod run;
mod spec;
mod teacher;
