#!/usr/bin/env bash
# The Python-trained agent of docs/onnx.md ("Your agent on your level"), end to end:
# train an rl-starter-files ACModel in PyTorch on a BabyAI level, export it, evaluate it with
# groundscope, replay the same episodes in minigrid with onnxruntime, and keep the graph and
# the Python episodes as fixtures (tests/it/env/levels.rs holds groundscope's episodes equal to
# them). Run from anywhere:
#
#   PYTHON=/path/to/venv/bin/python export/make_python_agent.sh [--retrain]
#
# PYTHON needs torch, numpy, gymnasium, minigrid==3.2.0, onnx and onnxruntime. Without
# --retrain the committed weights (experiments/acmodel/status.pt, from
# `train_acmodel.py --frames 600000`, stopped at 387,072 frames: about 34 minutes on 2 cores)
# are exported again; with it they are trained anew (torch's sampling makes a new run differ).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
LEVEL=BabyAI-GoToRedBallGrey-v0
RUN=experiments/acmodel
GRAPH=tests/fixtures/onnx/acmodel_gotoredballgrey.onnx
if [ "${1:-}" = "--retrain" ]; then
  "$PY" export/train_acmodel.py --env "$LEVEL" --frames 600000 --out "$RUN/run"
  cp "$RUN/run/status.pt" "$RUN/status.pt"
  cp "$RUN/run/log.csv" "$RUN/train_log.csv"
fi
"$PY" export/export_acmodel.py "$GRAPH" --status "$RUN/status.pt" \
  --level "{\"room_size\":8,\"n_objects\":4,\"tasks\":\"both\",\"done_required\":false,\"color_optional\":true,\"babyai\":\"$LEVEL\"}" \
  --name "ACModel trained in PyTorch on $LEVEL"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
cargo run --release --locked --quiet -- eval --checkpoint "$GRAPH" --levels "$LEVEL" \
  --seeds 5 --episodes 100 --quiet --out "$out"
"$PY" export/eval_in_python.py "$GRAPH" "$out/episodes.csv" \
  tests/fixtures/onnx/acmodel_gotoredballgrey_python.csv
