#!/bin/bash
# Traces of validation episodes (level seeds from 1,400,000) on the two levels with location
# words in the sixteen, read by location_words.py. Usage: run.sh CHECKPOINT OUT_DIR [EPISODES]
set -euo pipefail
ck=$1 out=$2 n=${3:-200}
here=$(cd "$(dirname "$0")" && pwd)
for level in PickupLoc OpenDoorLoc; do
  mkdir -p "$out/$level"
  for ((s = 1400000; s < 1400000 + n; s++)); do
    groundscope replay --checkpoint "$ck" --level "BabyAI-$level-v0" --seed "$s" --trace "$out/$level/$s.json" > /dev/null
  done
  echo "## $level"; echo
  python3 "$here/location_words.py" "$out/$level"
  echo
done
