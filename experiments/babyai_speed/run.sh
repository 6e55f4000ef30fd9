#!/usr/bin/env bash
# groundscope's world against minigrid 3.2.0, side by side: three alternating rounds per level,
# done-action mode on both sides, one thread, JSON lines to stdout.
#   experiments/babyai_speed/run.sh BIN PYTHON > results.jsonl
set -euo pipefail
bin="${1:?groundscope binary}"; py="${2:?python with minigrid==3.2.0}"
here="$(dirname "$0")"
export BABYAI_DONE_ACTIONS=1
for round in 1 2 3; do
  "$bin" bench env --level BabyAI-GoTo-v0 --done --steps 300000 --resets 30000
  "$py" "$here/minigrid_env_speed.py" --env BabyAI-GoTo-v0 --resets 1000 --steps 10000
  "$bin" bench env --steps 3000000 --resets 300000
  "$py" "$here/minigrid_env_speed.py" --env BabyAI-GoToLocalS8N4-v0 --resets 3000 --steps 30000
done
