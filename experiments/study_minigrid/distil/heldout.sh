#!/bin/bash
# Issue #82, stage 8: the held-out evaluation of the distilled pair, run once (2026-12-03 from
# 19:30 UTC) after the pre-registered rule chose it on validation seeds; the two models side by
# side, one core each. The same ids and seeds as the bundled pair's (../heldout/heldout.sh).
# The faithfulness step did not finish that session; it ran alone on 2026-12-04 on the same
# weights, trained again (SHA-256 checked), reports in heldout-faith/. The pair was bundled
# for an hour of 2026-12-04 (commit 07325c4), before stages 9 and 10 replaced it.
set -e
IDS=$(paste -sd, "$(dirname "$0")/../heldout/ids.txt")
LANG=MiniGrid-Fetch-5x5-N2-v0,MiniGrid-GoToObject-6x6-N2-v0,MiniGrid-GoToDoor-5x5-v0,MiniGrid-PutNear-6x6-N2-v0
R=studies/minigrid-distil/runs
(groundscope eval --checkpoint $R/dist_att-mg14-s1/model --levels "$IDS" \
  --first-seed 1500 --seeds 3 --episodes 100 --quiet --out studies/held8/eval-att &&
 groundscope faithfulness --checkpoint $R/dist_att-mg14-s1/model --levels "$LANG" \
  --first-seed 1500 --seeds 3 --episodes 20 --quiet --out studies/held8/faith) &
groundscope eval --checkpoint $R/dist_base-mg14-s1/model --levels "$IDS" \
  --first-seed 1500 --seeds 3 --episodes 100 --quiet --out studies/held8/eval-base
wait
