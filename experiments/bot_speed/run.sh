#!/usr/bin/env bash
# groundscope's bot against minigrid 3.2.0's BabyAIBot, side by side: the same levels and seeds,
# registered mode, one thread, alternating, JSON lines to stdout.
#   experiments/bot_speed/run.sh BIN PYTHON > results.jsonl
set -euo pipefail
bin="${1:?groundscope binary}"; py="${2:?python with minigrid==3.2.0}"
here="$(dirname "$0")"
levels="BabyAI-GoToLocal-v0,BabyAI-GoTo-v0,BabyAI-PutNextLocal-v0,BabyAI-UnlockPickup-v0,BabyAI-SynthS5R2-v0,BabyAI-BossLevel-v0"
export RAYON_NUM_THREADS=1
for round in 1 2; do
  "$py" "$here/minigrid_bot_speed.py" --levels "$levels" --episodes 40
  "$bin" bench bot --levels "$levels" --episodes 2000
done
