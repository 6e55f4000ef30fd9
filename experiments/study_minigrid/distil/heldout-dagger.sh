#!/bin/bash
# Issue #82, stage 10: the held-out evaluation of the DAgger pair (dagger_gl, dagger_base), run
# once (2026-12-04 from 19:50 UTC) after the pre-registered rule chose it on validation seeds.
# The ids and seeds of ../heldout/heldout.sh, each model's in two halves, two processes at a
# time (one core each; an episode depends on its id and seed only, so the halves are the whole
# evaluation); reports in heldout-dagger-{att,base}/part{1,2}/, each model's halves'
# performance.csv joined beside them, faithfulness in heldout-dagger-faith/; then the control
# (heldout-dagger-ctl/, heldout-dagger-ctl-faith/). The pair is bundled since:
# `--checkpoint bundled:minigrid` and `bundled:minigrid-baseline` open the same weights.
set -e
IDS="$(dirname "$0")/../heldout/ids.txt"
FIRST="$(head -38 "$IDS" | paste -sd,)"
REST="$(tail -n +39 "$IDS" | paste -sd,)"
LANG=MiniGrid-Fetch-5x5-N2-v0,MiniGrid-GoToObject-6x6-N2-v0,MiniGrid-GoToDoor-5x5-v0,MiniGrid-PutNear-6x6-N2-v0
R=studies/minigrid-dagger/runs
held() { groundscope eval --checkpoint "$R/$1/model" --levels "$2" \
  --first-seed 1500 --seeds 3 --episodes 100 --quiet --out "studies/held10/$3"; }
(held dagger_gl-mg14-s1 "$REST" att-2 && held dagger_base-mg14-s1 "$REST" base-2) &
long=$!
held dagger_gl-mg14-s1 "$FIRST" att-1
held dagger_base-mg14-s1 "$FIRST" base-1
groundscope faithfulness --checkpoint $R/dagger_gl-mg14-s1/model --levels "$LANG" \
  --first-seed 1500 --seeds 3 --episodes 20 --quiet --out studies/held10/faith
wait "$long"
# The unsupervised control `dagger_att`, evaluated the same way after the pair (20:07 UTC), for
# the control column beside the bundled model; it chooses nothing.
held dagger_att-mg14-s1 "$FIRST" ctl-1 &
ctl=$!
held dagger_att-mg14-s1 "$REST" ctl-2
wait "$ctl"
groundscope faithfulness --checkpoint $R/dagger_att-mg14-s1/model --levels "$LANG" \
  --first-seed 1500 --seeds 3 --episodes 20 --quiet --out studies/held10/ctl-faith
