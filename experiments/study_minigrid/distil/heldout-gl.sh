#!/bin/bash
# Issue #82, stage 9: the held-out evaluation of `dist_gl` (stage 8's attention student with
# --ground-loss 0.1), run once (2026-12-04 19:18-19:27 UTC) after the pre-registered rule chose
# it on validation seeds. The ids and seeds of ../heldout/heldout.sh, split in two halves run
# side by side (one core each; every episode depends on its id and seed only, so the halves
# are the whole evaluation); reports in heldout-gl/part{1,2}/, both halves' performance.csv
# joined in heldout-gl/performance.csv, faithfulness in heldout-gl-faith/. The checkpoint was
# bundled:minigrid for an hour of 2026-12-04 (commit f35a57d), before stage 10 replaced it.
set -e
IDS="$(dirname "$0")/../heldout/ids.txt"
LANG=MiniGrid-Fetch-5x5-N2-v0,MiniGrid-GoToObject-6x6-N2-v0,MiniGrid-GoToDoor-5x5-v0,MiniGrid-PutNear-6x6-N2-v0
C=studies/minigrid-distil-gl/runs/dist_gl-mg14-s1/model
groundscope eval --checkpoint $C --levels "$(head -38 "$IDS" | paste -sd,)" \
  --first-seed 1500 --seeds 3 --episodes 100 --quiet --out studies/held9/eval-1 &
first=$!
groundscope eval --checkpoint $C --levels "$(tail -n +39 "$IDS" | paste -sd,)" \
  --first-seed 1500 --seeds 3 --episodes 100 --quiet --out studies/held9/eval-2
wait "$first"
groundscope faithfulness --checkpoint $C --levels "$LANG" \
  --first-seed 1500 --seeds 3 --episodes 20 --quiet --out studies/held9/faith
