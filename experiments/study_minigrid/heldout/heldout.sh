#!/bin/bash
# The held-out evaluation of the bundled MiniGrid pair, run once (2026-12-03 05:45–06:30 UTC)
# after the pair was chosen on validation seeds: stage 2's pair then, whose reports these are
# (`git show 98afcf3:assets/minigrid.*` since stage 8's pair replaced it, ../distil/heldout.sh). ids.txt: MiniGrid's 76 ids less Playground,
# whose mission is empty (no model reads it and minigrid never rewards it).
set -e
IDS=$(paste -sd, "$(dirname "$0")/ids.txt")
LANG=MiniGrid-Fetch-5x5-N2-v0,MiniGrid-GoToObject-6x6-N2-v0,MiniGrid-GoToDoor-5x5-v0,MiniGrid-PutNear-6x6-N2-v0
groundscope eval --checkpoint bundled:minigrid --checkpoint bundled:minigrid-baseline --levels "$IDS" \
  --first-seed 1500 --seeds 3 --episodes 100 --quiet --out studies/held/eval
groundscope faithfulness --checkpoint bundled:minigrid --levels "$LANG" \
  --first-seed 1500 --seeds 3 --episodes 20 --quiet --out studies/held/faith
