#!/bin/bash
# The held-out success table over all 96 BabyAI ids (#64): bundled:babyai-grounded beside
# bundled:babyai and minigrid's bot, 3 seeds × 100 episodes per level from seed 1500 (the
# held-out seeds of every BabyAI table in docs/results.md). Eight levels per `eval` call, so
# that a stopped run resumes at the chunk it was in: a chunk with report.json is skipped.
#   experiments/all_levels/run.sh DIR [CHECKPOINT...]   (DIR: where the chunks' reports go;
#   the checkpoints default to the three above; bundled:babyai-grounded2 was added 2026-11-29
#   alone, `run.sh heldout2 bundled:babyai-grounded2`, and merged by collect.py with heldout/)
set -u
dir="${1:?usage: run.sh DIR [CHECKPOINT...]}"
shift
[ $# -gt 0 ] || set -- bundled:babyai-grounded bundled:babyai bot
ckpts=()
for c in "$@"; do ckpts+=(--checkpoint "$c"); done
here="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$dir"
for c in "$here"/heldout/chunk.*; do
  n="$(basename "$c")"
  [ -f "$dir/out-$n/report.json" ] && continue
  rm -rf "$dir/out-$n"
  groundscope eval "${ckpts[@]}" \
    --levels "$(paste -sd, "$c")" --first-seed 1500 --seeds 3 --episodes 100 --top-k 3 \
    --out "$dir/out-$n" > "$dir/log-$n.txt" 2>&1 || exit $?
done
python3 "$here/collect.py" "$dir"/out-chunk.* > "$dir/table.md"
