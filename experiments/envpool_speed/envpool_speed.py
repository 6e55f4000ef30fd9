#!/usr/bin/env python3
"""EnvPool 1.2.5's C++ BabyAI on one thread, as `groundscope bench env --level ID` measures
groundscope's: resets/s (`reset()` of 256 envs, level generation and first observation), then
steps/s of uniform random actions with EnvPool's own auto-reset, one JSON line per level.
EnvPool draws its levels from mt19937, so its levels are not minigrid's for the same seed;
this compares speed only. Run side by side with groundscope (run.sh).

  python envpool_speed.py --env BabyAI-GoTo-v0 --reset-batches 20 --step-batches 40
"""
import argparse
import json
import time

import envpool
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("--env", required=True)
ap.add_argument("--num-envs", type=int, default=256)
ap.add_argument("--reset-batches", type=int, default=20)
ap.add_argument("--step-batches", type=int, default=40)
a = ap.parse_args()

env = envpool.make_gymnasium(a.env, num_envs=a.num_envs, num_threads=1, seed=0)
env.reset()  # warm-up: allocation, first generation
t0 = time.perf_counter()
for _ in range(a.reset_batches):
    env.reset()
reset_secs = time.perf_counter() - t0

rng = np.random.default_rng(0)
actions = rng.integers(0, 7, (a.step_batches, a.num_envs))
env.reset()
t0 = time.perf_counter()
for act in actions:
    env.step(act)
step_secs = time.perf_counter() - t0
n = a.num_envs
print(json.dumps({
    "bench": "envpool-env", "level": a.env, "num_envs": n, "num_threads": 1,
    "resets_per_sec": round(a.reset_batches * n / reset_secs),
    "steps_per_sec": round(a.step_batches * n / step_secs),
    "resets": a.reset_batches * n, "steps": a.step_batches * n,
}))
