#!/usr/bin/env python3
"""minigrid 3.2.0's speed on a BabyAI level, as `groundscope bench env --level ID` measures
groundscope's: resets/s (reset(seed=s) for consecutive seeds, first observation included),
then steps/s of uniform random actions with auto-reset, one env, the unwrapped env, one JSON
line. Run side by side with groundscope (experiments/babyai_speed/run.sh).

  python minigrid_env_speed.py --env BabyAI-GoTo-v0 --resets 2000 --steps 20000
"""
import argparse
import contextlib
import io
import json
import time

import gymnasium as gym
import minigrid  # noqa: F401
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("--env", default="BabyAI-GoToLocalS8N4-v0")
ap.add_argument("--resets", type=int, default=2000)
ap.add_argument("--steps", type=int, default=20000)
a = ap.parse_args()

env = gym.make(a.env).unwrapped
sink = io.StringIO()
t0 = time.perf_counter()
with contextlib.redirect_stdout(sink):
    for seed in range(a.resets):
        env.reset(seed=seed)
reset_secs = time.perf_counter() - t0

rng = np.random.default_rng(0)
actions = rng.integers(0, 7, a.steps)
seed = 0
with contextlib.redirect_stdout(sink):
    env.reset(seed=seed)
t0 = time.perf_counter()
with contextlib.redirect_stdout(sink):
    for act in actions:
        _, _, term, trunc, _ = env.step(int(act))
        if term or trunc:
            seed += 1
            env.reset(seed=seed)
step_secs = time.perf_counter() - t0
print(json.dumps({
    "bench": "minigrid-env", "level": a.env, "resets_per_sec": round(a.resets / reset_secs),
    "steps_per_sec": round(a.steps / step_secs), "resets": a.resets, "steps": a.steps,
}))
