#!/usr/bin/env python3
"""Replay a ``groundscope eval`` run's episodes in minigrid with onnxruntime, and write the
same ``episodes.csv``: the check that groundscope evaluates your agent as your own Python
evaluation would.

    python export/eval_in_python.py GRAPH.onnx RUN/episodes.csv OUT.csv [--checkpoint NAME]

For every row of groundscope's ``episodes.csv`` (those of ``--checkpoint`` when the run
evaluated several) the script makes the row's level with ``gymnasium.make(level)``, resets it
with the row's ``level_seed`` (minigrid 3.2.0, the seeds groundscope used), and runs the graph
greedily — the action of the largest logit, as ``groundscope eval`` does without ``--sample``
— feeding it what rl-starter-files feeds a model: the view's codes as floats, the mission as
ids of the graph's own vocabulary (metadata ``groundscope.vocabulary``), split as BabyAI
splits it, ``re.findall("([a-z]+)", mission.lower())``, and the memory it returned at the
previous step (zeros at the first). It writes one row per episode with groundscope's
columns: the mission minigrid generated, success, steps, return and the actions taken;
``failure_class`` is groundscope's own analysis and stays empty here.

Needs numpy, gymnasium, minigrid==3.2.0 and onnxruntime. Only registered BabyAI levels can be
replayed here (the paper's level, ``groundscope-PaperLocal…``, is a class of docs/world.md,
not registered in minigrid). Exit status: 0 when every episode was replayed, 2 on bad input.
"""

from __future__ import annotations

import argparse
import csv
import json
import re
import sys

import gymnasium as gym
import minigrid  # noqa: F401  (registers the BabyAI levels)
import numpy as np
import onnxruntime as ort

HEADER = [
    "checkpoint", "level", "eval_seed", "episode", "level_seed", "mission", "success", "steps",
    "return", "failure_class", "actions",
]
# Columns groundscope writes after HEADER (the episode beside minigrid's bot, docs/bot.md);
# this script leaves them out of its own file.


def fail(msg: str) -> None:
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(2)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("graph", help="the ONNX graph groundscope evaluated")
    ap.add_argument("episodes", help="groundscope's episodes.csv (from `groundscope eval`)")
    ap.add_argument("out", help="the episodes.csv to write")
    ap.add_argument("--checkpoint", help="replay only this checkpoint's rows")
    args = ap.parse_args()

    sess = ort.InferenceSession(args.graph, providers=["CPUExecutionProvider"])
    meta = sess.get_modelmeta().custom_metadata_map
    try:
        vocabulary = json.loads(meta["groundscope.vocabulary"])
        memory_size = int(meta["groundscope.memory_size"])
    except (KeyError, ValueError) as e:
        fail(f"{args.graph}: metadata groundscope.vocabulary / memory_size missing or bad: {e}")
    ids = {w: i for i, w in enumerate(vocabulary)}
    inputs = {i.name for i in sess.get_inputs()}
    if not {"image", "mission", "memory"} <= inputs:
        fail(f"{args.graph}: inputs {sorted(inputs)}; this script feeds image, mission, memory")

    with open(args.episodes, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or list(rows[0].keys())[: len(HEADER)] != HEADER:
        fail(f"{args.episodes}: not a groundscope episodes.csv (header {HEADER})")
    # minigrid's registered levels end an episode when the instruction is satisfied; rows of
    # groundscope's done-action mode (`--done`, the paper's) would replay in the wrong mode.
    done_rows = [r for r in rows if r.get("done_required") == "1"]
    if done_rows:
        r = done_rows[0]
        fail(f"{args.episodes}: {len(done_rows)} rows ran in the done-action mode (first: "
             f"{r['checkpoint']} {r['level']} seed {r['level_seed']}); minigrid's registered "
             f"levels do not require 'done', so they cannot be replayed here: evaluate without --done")
    if args.checkpoint is not None:
        rows = [r for r in rows if r["checkpoint"] == args.checkpoint]
        if not rows:
            fail(f"{args.episodes}: no rows of checkpoint {args.checkpoint!r}")

    out_rows = []
    envs: dict[str, gym.Env] = {}
    for r in rows:
        level = r["level"]
        if level not in envs:
            if level not in gym.registry:
                fail(f"{args.episodes}: level {level!r} is not registered in minigrid")
            envs[level] = gym.make(level)
        env = envs[level]
        obs, _ = env.reset(seed=int(r["level_seed"]))
        mission = obs["mission"]
        words = re.findall("([a-z]+)", mission.lower())
        unknown = [w for w in words if w not in ids]
        if unknown:
            fail(f"mission {mission!r}: the graph's vocabulary has no {unknown[0]!r}")
        text = np.array([[ids[w] for w in words]], dtype=np.int64)
        memory = np.zeros((1, memory_size), dtype=np.float32)
        actions, total, steps, success = [], 0.0, 0, False
        while True:
            image = obs["image"][None].astype(np.float32)
            logits, _value, memory = sess.run(
                ["logits", "value", "memory_out"],
                {"image": image, "mission": text, "memory": memory},
            )
            action = int(np.argmax(logits[0]))
            obs, reward, terminated, truncated, _ = env.step(action)
            actions.append(action)
            total += float(reward)
            steps += 1
            if terminated or truncated:
                success = reward > 0
                break
        out_rows.append({
            "checkpoint": r["checkpoint"], "level": level, "eval_seed": r["eval_seed"],
            "episode": r["episode"], "level_seed": r["level_seed"], "mission": mission,
            "success": int(success), "steps": steps, "return": f"{total:.6f}",
            "failure_class": "", "actions": " ".join(map(str, actions)),
        })

    with open(args.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=HEADER, lineterminator="\n")
        w.writeheader()
        w.writerows(out_rows)
    same = sum(
        a["actions"] == b["actions"] and a["mission"] == b["mission"]
        for a, b in zip(rows, out_rows)
    )
    print(f"replayed {len(out_rows)} episodes; {same} take groundscope's actions exactly; "
          f"success {np.mean([int(r['success']) for r in out_rows]):.3f}; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
