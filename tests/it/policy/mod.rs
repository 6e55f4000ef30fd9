//! The policy: gradients, checkpoints and traces (`net`), the fused kernels against their
//! references (`fused`, `fused_sequence`), the model options of issue #64 (`ground_loss`,
//! `filter_norm`, `layout_path`) and what a word's map can see (`word_maps`).

mod filter_norm;
mod fused;
mod fused_sequence;
mod ground_loss;
mod layout_path;
mod net;
mod word_maps;
