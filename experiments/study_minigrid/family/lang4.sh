#!/bin/bash
# Stage 7's evaluation of the lang4 family pair (README.md, "Stage 7"), run from the directory
# that holds studies/minigrid-fam: faithfulness on validation seeds first, then, because the
# attention model's validation success (0.545) beat bundled:minigrid's 0.260 on these four ids
# by more than 0.01, the held-out figures once, on the seeds heldout/heldout.sh used.
set -e
LANG=MiniGrid-Fetch-5x5-N2-v0,MiniGrid-GoToObject-6x6-N2-v0,MiniGrid-GoToDoor-5x5-v0,MiniGrid-PutNear-6x6-N2-v0
RUNS=studies/minigrid-fam/runs
groundscope faithfulness --checkpoint $RUNS/att-lang4-s1/model --levels "$LANG" \
  --first-seed 1400 --seeds 1 --episodes 20 --quiet --out studies/fam-lang4/val-faith
groundscope eval --checkpoint $RUNS/att-lang4-s1/model --checkpoint $RUNS/base-lang4-s1/model \
  --levels "$LANG" --first-seed 1500 --seeds 3 --episodes 100 --quiet --out studies/fam-lang4/held-eval
groundscope faithfulness --checkpoint $RUNS/att-lang4-s1/model --levels "$LANG" \
  --first-seed 1500 --seeds 3 --episodes 20 --quiet --out studies/fam-lang4/held-faith
