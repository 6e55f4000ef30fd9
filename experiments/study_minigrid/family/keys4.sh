#!/bin/bash
# Stage 7's held-out evaluation of the keys4 family pair (README.md, "Stage 7"), run once from
# the directory that holds studies/minigrid-fam, because the attention model's validation
# success (0.935) beat bundled:minigrid's 0.510 on these four ids by more than 0.01.
set -e
KEYS=MiniGrid-DoorKey-5x5-v0,MiniGrid-Unlock-v0,MiniGrid-KeyCorridorS3R1-v0,MiniGrid-DoorKey-8x8-v0
RUNS=studies/minigrid-fam/runs
groundscope eval --checkpoint $RUNS/att-keys4-s1/model --checkpoint $RUNS/base-keys4-s1/model \
  --levels "$KEYS" --first-seed 1500 --seeds 3 --episodes 100 --quiet --out studies/fam-keys4/held-eval
