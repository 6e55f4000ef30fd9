//! ONNX import (docs/onnx.md): imported graphs acting, refused and traced (`import`), their
//! faithfulness and saliency (`faithfulness`), and rl-starter-files' agents of MiniGrid's own
//! environments, without memory or a mission input (`minigrid`); the occlusion map recomputed
//! from a trace (`occlusion`).

mod faithfulness;
mod import;
mod minigrid;
mod occlusion;
