#!/usr/bin/env python3
"""Random-action steps/s of a 64-env vector BabyAI env: groundscope.make_vec against
gymnasium's sync vector env over minigrid 3.2.0 and EnvPool 1.2.5 (where installed), on one
thread and on every core. One JSON line per measurement, then a Markdown table.

  python experiments/python_speed/bench_vec.py --env BabyAI-GoToLocal-v0 --seconds 5

Every contender gets the same pre-drawn uniform actions; the clock runs over `step` calls
only (autoresets included, as each library does them: NEXT_STEP for groundscope and
gymnasium, EnvPool's own). Observations are copied out as gymnasium's default does.
"""

import argparse
import contextlib
import io
import json
import os
import platform
import time

import gymnasium as gym
import numpy as np

import groundscope


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def timed(step, actions, seconds):
    """Steps through `actions` (T, N) cyclically for about `seconds`; env-steps/s."""
    n = actions.shape[1]
    done = 0
    t0 = time.perf_counter()
    while True:
        for a in actions:
            step(a)
        done += len(actions)
        elapsed = time.perf_counter() - t0
        if elapsed >= seconds:
            return done * n / elapsed


def bench_groundscope(env_id, n, threads, actions, seconds):
    envs = groundscope.make_vec(env_id, n, num_threads=threads)
    envs.reset(seed=0)
    return timed(envs.step, actions, seconds)


def bench_gymnasium(env_id, n, actions, seconds):
    import minigrid

    gym.register_envs(minigrid)
    envs = gym.make_vec(env_id, n, vectorization_mode="sync")
    # minigrid prints every rejected level ("Sampling rejected: ..."); not part of the cost.
    with contextlib.redirect_stdout(io.StringIO()):
        envs.reset(seed=0)
        return timed(envs.step, actions, seconds)


def bench_envpool(env_id, n, threads, actions, seconds):
    import envpool

    envs = envpool.make_gymnasium(env_id, num_envs=n, num_threads=threads, seed=0)
    envs.reset()
    return timed(envs.step, actions, seconds)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", action="append", help="BabyAI id (repeatable)")
    ap.add_argument("--num-envs", type=int, default=64)
    ap.add_argument("--seconds", type=float, default=5.0, help="per measurement")
    ap.add_argument("--skip", action="append", default=[], help="gymnasium, envpool")
    a = ap.parse_args()
    env_ids = a.env or ["BabyAI-GoToLocal-v0", "BabyAI-BossLevel-v0"]
    cores = os.cpu_count() or 1
    rng = np.random.default_rng(0)
    actions = rng.integers(0, 7, (256, a.num_envs)).astype(np.int64)
    machine = {
        "date": time.strftime("%Y-%m-%d"),
        "cpu": cpu_name(),
        "cores": cores,
        "python": platform.python_version(),
        "groundscope": "python package 0.1.0",
        "numpy": np.__version__,
        "gymnasium": gym.__version__,
    }
    rows = []
    for env_id in env_ids:
        runs = [("groundscope", 1, lambda: bench_groundscope(env_id, a.num_envs, 1, actions, a.seconds))]
        if cores > 1:
            runs.append(
                ("groundscope", cores, lambda: bench_groundscope(env_id, a.num_envs, cores, actions, a.seconds))
            )
        if "gymnasium" not in a.skip:
            runs.append(("gymnasium sync + minigrid 3.2.0", 1, lambda: bench_gymnasium(env_id, a.num_envs, actions[:32], a.seconds)))
        if "envpool" not in a.skip:
            for t in sorted({1, cores}):
                runs.append(("envpool 1.2.5", t, lambda t=t: bench_envpool(env_id, a.num_envs, t, actions, a.seconds)))
        for name, threads, run in runs:
            try:
                sps = run()
            except ImportError as e:
                print(f"# {name}: not installed ({e})")
                continue
            row = {"env": env_id, "impl": name, "threads": threads, "num_envs": a.num_envs, "steps_per_sec": round(sps)} | machine
            rows.append(row)
            print(json.dumps(row), flush=True)
    print()
    print(f"{machine['date']}, {machine['cpu']}, {cores} cores, Python {machine['python']}, {a.num_envs} envs:")
    print()
    print("| level | implementation | threads | env steps/s | groundscope (same threads) × |")
    print("|---|---|---:|---:|---:|")
    for r in rows:
        ours = next(
            (x["steps_per_sec"] for x in rows if x["env"] == r["env"] and x["impl"] == "groundscope" and x["threads"] == r["threads"]),
            None,
        )
        ratio = f"{ours / r['steps_per_sec']:.1f}" if ours and r["impl"] != "groundscope" else ""
        print(f"| {r['env']} | {r['impl']} | {r['threads']} | {r['steps_per_sec']:,} | {ratio} |")


if __name__ == "__main__":
    main()
