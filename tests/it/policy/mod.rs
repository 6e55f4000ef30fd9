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

/// A parent of BabyAI's grammar without the layout path or the filter norm, for the tests that
/// grow one: `bundled:babyai`'s shape with both options off, freshly initialised (the bundled
/// agent has both since 2026-12-02, and growing a model is exact whatever its weights).
pub fn plain_babyai_parent() -> (
    groundscope::policy::ModelConfig,
    groundscope::policy::Params,
) {
    let bundled = groundscope::policy::bundled::load(groundscope::policy::bundled::BABYAI).unwrap();
    let cfg = groundscope::policy::ModelConfig {
        layout_path: false,
        filter_norm: false,
        ..bundled.meta.model
    };
    let params = groundscope::policy::Params::init(&cfg, 7).unwrap();
    (cfg, params)
}
