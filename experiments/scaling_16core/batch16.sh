#!/bin/bash
# Does a bigger PPO batch scale over 16 threads? train on the paper's level, 64 envs x 128 frames
# (8,192 frames/update), 1,024-frame minibatches, 1 vs 4 vs 16 threads; and the default recipe
# (16 x 128, 256-frame minibatches) at 1 and 8 threads for reference. Frames/s from log.csv.
set -u
cd "$(dirname "$0")/.."
xz -dc .devpack/gs.xz > /tmp/gs && chmod +x /tmp/gs || exit 1
export RAYON_NUM_THREADS=1
{ date -u; nproc; lscpu | grep "Model name"; } | tee $OUT/machine.txt
run() { # name frames threads args...
  local name=$1 frames=$2 th=$3; shift 3
  local t0=$(date +%s.%N)
  /tmp/gs train --out /tmp/$name --frames $frames --threads $th --save-interval 1000 --eval-interval 0 --quiet "$@" > /tmp/$name.out 2>&1
  local t1=$(date +%s.%N)
  echo "$name threads=$th frames=$frames wall=$(python3 -c "print(round($t1 - $t0, 2))") last_log=$(tail -1 /tmp/$name/log.csv)"
}
{
run big1 163840 1 --procs 64 --batch-size 1024
run big4 163840 4 --procs 64 --batch-size 1024
run big16 327680 16 --procs 64 --batch-size 1024
run def1 102400 1
run def8 102400 8
} 2>&1 | tee $OUT/batch16.txt
