#!/usr/bin/env bash
# Regenerates every ONNX fixture of tests/fixtures/onnx/ (how each is made:
# tests/fixtures/onnx/README.md; the contract: docs/onnx.md) but the GoToRedBallGrey agent of
# make_python_agent.sh (which needs groundscope). Run from anywhere:
#
#   PYTHON=/path/to/venv/bin/python export/make_fixtures.sh
#
# PYTHON: an interpreter with export/requirements.txt installed (default python3).
# TORCH_REFERENCE: the torch reference's model.py (default ../shared/tools/torch-reference/model.py,
# beside this repository). With the pinned versions, repeated runs on one machine write the
# same bytes; another CPU may draw other random weights in their last bits (PyTorch's
# vectorised normal_), and so train other MiniGrid agents, whose Python evaluations are
# regenerated with them.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
REF=${TORCH_REFERENCE:-../shared/tools/torch-reference/model.py}
OUT=tests/fixtures/onnx
mkdir -p "$OUT"

"$PY" export/native_to_onnx.py assets/attention "$OUT/bundled_attention.onnx" \
    --name "bundled attention (ONNX export)"
"$PY" export/export_acmodel.py "$OUT/acmodel.onnx"
"$PY" export/export_torch_reference.py "$OUT/torch_reference.onnx" --model-py "$REF"
"$PY" export/make_bad_fixtures.py "$OUT"

# rl-starter-files' ACModel on MiniGrid's own environments, trained here briefly.
PYTHON="$PY" export/make_minigrid_agents.sh
ls -l "$OUT"/*.onnx
