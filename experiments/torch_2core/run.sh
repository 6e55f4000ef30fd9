#!/usr/bin/env bash
# groundscope's PPO end to end against the PyTorch reference on the 2-core machine, side by
# side: ROUNDS alternations of `bench train --threads 1,2` (102,400 frames, the paper's level)
# and `train_ppo.py --threads 2` (100,000 frames, minigrid's GoToLocalS8N4; same network, PPO
# configuration and batch shapes), nothing else running. JSON lines and torch's last line.
#   experiments/torch_2core/run.sh BIN PYTHON TORCH_REFERENCE_DIR > out.txt
set -euo pipefail
bin="${1:?groundscope binary}"; py="${2:?python with torch, gymnasium, minigrid 3.2.0}"
ref="${3:?torch-reference directory}"
export RAYON_NUM_THREADS=1
for r in $(seq "${ROUNDS:-2}"); do
  echo "# round $r $(date -u +%H:%M:%S)"
  "$bin" bench train --frames 102400 --threads 1,2
  (cd "$ref" && "$py" train_ppo.py --threads 2 --max-frames 100000 --max-seconds 600 | tail -1)
done
