//! ONNX import (docs/onnx.md): imported graphs acting, refused and traced (`import`), and their
//! faithfulness and saliency (`faithfulness`).

mod faithfulness;
mod import;
