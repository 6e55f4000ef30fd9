#!/usr/bin/env bash
# groundscope's world against EnvPool 1.2.5's C++ BabyAI (and, with a third argument, minigrid
# 3.2.0), side by side on every BabyAI id both register: for each id, groundscope then EnvPool
# (then minigrid), one thread each, in the level's registered mode; JSON lines to stdout.
#   experiments/envpool_speed/run.sh BIN PYTHON [MINIGRID_PYTHON] > results.jsonl
#   python3 experiments/envpool_speed/summary.py results.jsonl > results.md
# PYTHON needs envpool==1.2.5 (it installs on Python 3.11); MINIGRID_PYTHON minigrid==3.2.0.
# ROUNDS=N (default 1) alternates the two sides N times per level; summary.py takes medians.
# IDS="id id ..." measures those levels only (default: every BabyAI id EnvPool registers).
# MG_RESETS=N (default 300) resets on minigrid's side, once per level (it is the slow side).
set -euo pipefail
bin="${1:?groundscope binary}"; py="${2:?python with envpool==1.2.5}"; mg="${3:-}"
here="$(dirname "$0")"
export RAYON_NUM_THREADS=1
ids="${IDS:-$("$py" -c 'import envpool; print(" ".join(e for e in envpool.list_all_envs() if e.startswith("BabyAI-")))')}"
for id in $ids; do
  for _ in $(seq "${ROUNDS:-1}"); do
    "$bin" bench env --level "$id" --steps 2000000 --resets 200000 || echo "{\"bench\":\"env\",\"level\":\"$id\",\"error\":true}"
    "$py" "$here/envpool_speed.py" --env "$id" --reset-batches 60 --step-batches 200 || echo "{\"bench\":\"envpool-env\",\"level\":\"$id\",\"error\":true}"
  done
  if [ -n "$mg" ]; then
    "$mg" "$here/../babyai_speed/minigrid_env_speed.py" --env "$id" --resets "${MG_RESETS:-300}" --steps 3000
  fi
done
