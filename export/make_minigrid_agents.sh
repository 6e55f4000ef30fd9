#!/usr/bin/env bash
# The MiniGrid agents of tests/fixtures/onnx/ (issue #82 item 4; make_fixtures.sh runs this
# too): rl-starter-files' ACModel trained in PyTorch on MiniGrid's own environments — image
# only and with memory on MiniGrid-DoorKey-5x5-v0, with memory and text on
# MiniGrid-Fetch-5x5-N2-v0 — briefly (100,000 frames each, seed 1, one thread: about a minute
# apiece on 2 cores), exported with the level's id as their level, and evaluated in minigrid
# with onnxruntime on 3 seeds x 10 episodes of each level of a small sweep
# (NAME_python.csv). tests/it/onnx/minigrid.rs holds `groundscope eval` equal to these Python
# evaluations episode by episode, python/tests/test_onnx_parity.py holds groundscope.evaluate
# of a Python callable running the graph with onnxruntime equal to them. The weights are not
# kept: the run is the recipe (another CPU may train other weights; the graphs and their
# Python evaluations are regenerated together). Run from anywhere:
#
#   PYTHON=/path/to/venv/bin/python export/make_minigrid_agents.sh
#
# PYTHON needs export/requirements.txt (torch, onnx, onnxruntime, numpy, gymnasium,
# minigrid==3.2.0).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
OUT=tests/fixtures/onnx
mkdir -p "$OUT"
runs=$(mktemp -d)
trap 'rm -rf "$runs"' EXIT
minigrid_agent() {  # NAME ENV "TRAIN FLAGS" LEVELS DESCRIPTION
  local name=$1 env=$2 flags=$3 levels=$4 what=$5
  # shellcheck disable=SC2086  # the flags are words
  "$PY" export/train_acmodel.py --env "$env" $flags --frames 100000 --seed 1 --threads 1 \
    --out "$runs/$name"
  tail -n 1 "$runs/$name/log.csv"
  "$PY" export/export_acmodel.py "$OUT/$name.onnx" --status "$runs/$name/status.pt" \
    --level "$env" --name "ACModel $what, trained in PyTorch on $env (100k frames)"
  "$PY" export/eval_in_python.py "$OUT/$name.onnx" --levels "$levels" --seeds 3 --episodes 10 \
    --min-gap 1e-4 "$OUT/${name}_python.csv"
}
minigrid_agent acmodel_doorkey MiniGrid-DoorKey-5x5-v0 "--no-mem --no-text" \
  MiniGrid-DoorKey-5x5-v0,MiniGrid-DoorKey-6x6-v0,MiniGrid-Empty-5x5-v0 "image only"
minigrid_agent acmodel_doorkey_mem MiniGrid-DoorKey-5x5-v0 "--mem --no-text" \
  MiniGrid-DoorKey-5x5-v0,MiniGrid-DoorKey-6x6-v0 "with memory"
minigrid_agent acmodel_fetch MiniGrid-Fetch-5x5-N2-v0 "--mem --text" \
  MiniGrid-Fetch-5x5-N2-v0,MiniGrid-Fetch-6x6-N2-v0 "with memory and text"
ls -l "$OUT"/acmodel_doorkey*.onnx "$OUT"/acmodel_fetch.onnx
