#!/bin/bash
# 16-core scaling of groundscope train / eval / faithfulness, PyTorch reference on the GPU beside.
set -u
cd "$(dirname "$0")/.."
xz -dc .devpack/gs.xz > /tmp/gs && chmod +x /tmp/gs || exit 1
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .devpack/whl/*.whl && export PYTHONPATH=/tmp/site
{ date -u; nproc; lscpu | grep -E "Model name|^CPU\(s\)|Thread|Core|Socket"; nvidia-smi -L; free -g | head -2; } 2>&1 | tee $OUT/machine.txt
TIMEFORMAT='%R s'
echo "== bench train, RAYON_NUM_THREADS=1" | tee $OUT/bench_train.txt
RAYON_NUM_THREADS=1 /tmp/gs bench train --threads 1,2,4,8,16 --frames ${FR:-102400} 2>&1 | tee -a $OUT/bench_train.txt
echo "== bench train, rayon default (candle kernels threaded too)" | tee -a $OUT/bench_train.txt
/tmp/gs bench train --threads 1,16 --frames 51200 2>&1 | tee -a $OUT/bench_train.txt
echo "== eval / faithfulness --jobs" | tee $OUT/jobs.txt
for j in 1 4 16; do echo "eval jobs $j"; { time RAYON_NUM_THREADS=1 /tmp/gs eval --seeds 4 --episodes 100 --jobs $j --out /tmp/ev$j --quiet >/dev/null; } 2>&1; done 2>&1 | tee -a $OUT/jobs.txt
for j in 1 4 16; do echo "faithfulness jobs $j"; { time RAYON_NUM_THREADS=1 /tmp/gs faithfulness --seeds 4 --episodes 100 --jobs $j --out /tmp/fa$j --quiet >/dev/null; } 2>&1; done 2>&1 | tee -a $OUT/jobs.txt
cmp /tmp/ev1/episodes.csv /tmp/ev16/episodes.csv && echo "eval episodes.csv identical for jobs 1 and 16" | tee -a $OUT/jobs.txt
cd .devpack/torch-reference
echo "== torch cuda" > $OUT/torch.txt
timeout 110 python3 -u train_ppo.py --device cuda --env-workers 16 --threads 16 --max-frames 81920 --max-seconds 70 2>&1 | grep -v "^U " | tee -a $OUT/torch.txt
echo "== torch cpu 16 threads" >> $OUT/torch.txt
timeout 80 python3 -u train_ppo.py --device cpu --env-workers 16 --threads 16 --max-frames 61440 --max-seconds 40 2>&1 | grep -v "^U " | tee -a $OUT/torch.txt
