#!/usr/bin/env python3
"""minigrid 3.2.0's BabyAIBot alone, one thread: demonstrations per second on each level, in
the level's registered mode (no done action), seeds 0..N — what `groundscope bench bot` times,
as one JSON line per level in the same shape.

    python experiments/bot_speed/minigrid_bot_speed.py --levels BabyAI-GoTo-v0 --episodes 50

Needs: pip install minigrid==3.2.0.
"""
import argparse
import json
import time

import gymnasium as gym
import minigrid  # noqa: F401  (registers the BabyAI levels)
from minigrid.utils.baby_ai_bot import BabyAIBot


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--levels", required=True, help="BabyAI ids, comma-separated")
    ap.add_argument("--episodes", type=int, default=50)
    args = ap.parse_args()
    for level in args.levels.split(","):
        env = gym.make(level)
        steps = successes = gave_up = 0
        start = time.perf_counter()
        for seed in range(args.episodes):
            env.reset(seed=seed)
            bot = BabyAIBot(env)
            taken = None
            while True:
                try:
                    action = bot.replan(taken)
                except Exception:  # noqa: BLE001  (the bot gives up on some states)
                    gave_up += 1
                    break
                _, reward, terminated, truncated, _ = env.step(action)
                taken = action
                steps += 1
                if terminated or truncated:
                    successes += reward > 0
                    break
        secs = time.perf_counter() - start
        print(json.dumps({
            "bench": "minigrid_bot", "level": level, "episodes": args.episodes, "steps": steps,
            "success": successes / args.episodes, "gave_up": gave_up,
            "demos_per_sec": round(args.episodes / secs, 1), "steps_per_sec": round(steps / secs),
            "threads": 1, "elapsed_secs": secs,
        }), flush=True)


if __name__ == "__main__":
    main()
