#!/usr/bin/env python3
"""Evaluate an ONNX graph of groundscope's contract in minigrid with onnxruntime and write
groundscope's ``episodes.csv``: the check that groundscope evaluates your agent as your own
Python evaluation would.

    python export/eval_in_python.py GRAPH.onnx RUN/episodes.csv OUT.csv [--checkpoint NAME]
    python export/eval_in_python.py GRAPH.onnx --levels ID[,ID…] [--seeds S] [--episodes E]
        [--first-seed F] OUT.csv

The first form replays the rows of a ``groundscope eval`` run's ``episodes.csv`` (those of
``--checkpoint`` when the run evaluated several); the second makes the rows ``groundscope eval
--levels ID,… --seeds S --episodes E`` would run, in its order — each level, evaluation seeds
``F … F+S−1``, episodes ``0 … E−1``, level seed ``s·10⁶ + e`` — without groundscope. Either
way every row's level is made with ``gymnasium.make(level)`` (any id minigrid 3.2.0
registers: BabyAI's and MiniGrid's own), reset with the row's ``level_seed``, and the graph
is run greedily — the action of the largest logit, as ``groundscope eval`` does without
``--sample`` — fed what rl-starter-files feeds a model: the view's codes as floats (or
int64, as the graph declares), and where the graph takes them the mission as ids of its own
vocabulary (metadata ``groundscope.vocabulary``), split as BabyAI splits it,
``re.findall("([a-z]+)", mission.lower())``, and the memory it returned at the previous step
(zeros at the first). A graph without a ``mission`` input is fed none (no word of the
mission is looked up), one without memory (no ``memory``/``memory_out``) none. It writes one
row per episode with groundscope's columns: the mission minigrid generated, success (the
last reward > 0), steps, return and the actions taken; ``failure_class`` is groundscope's
own analysis and stays empty here. It prints the smallest gap between the largest and the
second largest logit over every step: a gap of float32 rounding (1e-6) would let two
runtimes take different actions (``--min-gap`` makes that an error).

Needs numpy, gymnasium, minigrid==3.2.0 and onnxruntime. The paper's level,
``groundscope-PaperLocal…``, is a class of docs/world.md, not registered in minigrid, so it
cannot be replayed here. Exit status: 0 when every episode was replayed, 1 when a logit gap
is under ``--min-gap``, 2 on bad input.
"""

from __future__ import annotations

import argparse
import csv
import json
import re
import sys

import gymnasium as gym
import minigrid  # noqa: F401  (registers the BabyAI and MiniGrid levels)
import numpy as np
import onnxruntime as ort

HEADER = [
    "checkpoint", "level", "eval_seed", "episode", "level_seed", "mission", "success", "steps",
    "return", "failure_class", "actions",
]
# Columns groundscope writes after HEADER (the episode beside minigrid's bot, docs/bot.md);
# this script leaves them out of its own file.
# groundscope's level seeds: episode e of evaluation seed s is s·10⁶ + e (src/env/seeds.rs).
EPISODES_PER_EVAL_SEED = 1_000_000


def fail(msg: str) -> None:
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(2)


class Graph:
    """The ONNX graph and what it reads: the inputs it takes, its vocabulary and memory."""

    def __init__(self, path: str):
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = 1
        opts.inter_op_num_threads = 1
        self.sess = ort.InferenceSession(path, opts, providers=["CPUExecutionProvider"])
        meta = self.sess.get_modelmeta().custom_metadata_map
        self.inputs = {i.name: i.type for i in self.sess.get_inputs()}
        self.outputs = [o.name for o in self.sess.get_outputs()]
        if "image" not in self.inputs or not {"logits", "value"} <= set(self.outputs):
            fail(f"{path}: inputs {sorted(self.inputs)}, outputs {self.outputs}; the contract "
                 "needs image in, logits and value out")
        unknown = set(self.inputs) - {"image", "mission", "memory", "direction"}
        if unknown:
            fail(f"{path}: inputs {sorted(unknown)} are not fed by this script")
        self.mission = "mission" in self.inputs
        self.memory = "memory" in self.inputs
        try:
            vocabulary = json.loads(meta["groundscope.vocabulary"]) if self.mission else []
            self.memory_size = int(meta.get("groundscope.memory_size", "0")) if self.memory else 0
        except (KeyError, ValueError) as e:
            fail(f"{path}: metadata groundscope.vocabulary / memory_size missing or bad: {e}")
        self.ids = {w: i for i, w in enumerate(vocabulary)}
        self.image_dtype = np.int64 if self.inputs["image"] == "tensor(int64)" else np.float32
        self.fetch = ["logits"] + (["memory_out"] if self.memory else [])

    def text(self, mission: str) -> np.ndarray | None:
        """The mission's ids (1, L), or None for a graph that reads no mission."""
        if not self.mission:
            return None
        words = re.findall("([a-z]+)", mission.lower())
        unknown = [w for w in words if w not in self.ids]
        if unknown:
            fail(f"mission {mission!r}: the graph's vocabulary has no {unknown[0]!r}")
        return np.array([[self.ids[w] for w in words]], dtype=np.int64)


def episode(graph: Graph, env: gym.Env, seed: int) -> tuple[dict, float]:
    """One greedy episode from ``reset(seed=seed)``: the row's outcome and the smallest gap
    between the two largest logits."""
    obs, _ = env.reset(seed=seed)
    mission = obs["mission"]
    text = graph.text(mission)
    memory = np.zeros((1, graph.memory_size), dtype=np.float32)
    actions, total, steps, success, gap = [], 0.0, 0, False, np.inf
    while True:
        feed = {"image": obs["image"][None].astype(graph.image_dtype)}
        if graph.mission:
            feed["mission"] = text
        if graph.memory:
            feed["memory"] = memory
        if "direction" in graph.inputs:
            feed["direction"] = np.array([obs["direction"]], dtype=np.int64)
        out = graph.sess.run(graph.fetch, feed)
        logits = out[0][0]
        if graph.memory:
            memory = out[1]
        top = np.sort(logits.astype(np.float64))[-2:]
        gap = min(gap, float(top[1] - top[0]))
        action = int(np.argmax(logits))
        obs, reward, terminated, truncated, _ = env.step(action)
        actions.append(action)
        total += float(reward)
        steps += 1
        if terminated or truncated:
            success = reward > 0
            break
    row = {"mission": mission, "success": int(success), "steps": steps,
           "return": f"{total:.6f}", "failure_class": "", "actions": " ".join(map(str, actions))}
    return row, gap


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("graph", help="the ONNX graph")
    ap.add_argument("files", nargs="+", metavar="[EPISODES.csv] OUT.csv",
                    help="groundscope's episodes.csv to replay (not with --levels), then the "
                    "episodes.csv to write")
    ap.add_argument("--checkpoint", help="replay only this checkpoint's rows")
    ap.add_argument("--levels", help="comma-separated level ids: run these episodes instead")
    ap.add_argument("--seeds", type=int, default=5, help="evaluation seeds (with --levels)")
    ap.add_argument("--episodes", type=int, default=100, help="episodes per seed (--levels)")
    ap.add_argument("--first-seed", type=int, default=0, help="first evaluation seed (--levels)")
    ap.add_argument("--name", help="the checkpoint column (with --levels; default the graph "
                    "as given, as groundscope eval writes it)")
    ap.add_argument("--min-gap", type=float, default=0.0,
                    help="exit 1 when the smallest gap between the two largest logits of a step "
                    "is below this (a test fixture whose actions two runtimes could choose "
                    "differently)")
    args = ap.parse_args()

    graph = Graph(args.graph)
    if args.levels is not None:
        if len(args.files) != 1:
            fail("with --levels give one file: the episodes.csv to write")
        out_path = args.files[0]
        name = args.name or args.graph
        rows = [
            {"checkpoint": name, "level": level, "eval_seed": str(s), "episode": str(e),
             "level_seed": str(s * EPISODES_PER_EVAL_SEED + e)}
            for level in args.levels.split(",")
            for s in range(args.first_seed, args.first_seed + args.seeds)
            for e in range(args.episodes)
        ]
    else:
        if len(args.files) != 2:
            fail("give groundscope's episodes.csv and the episodes.csv to write (or --levels)")
        episodes, out_path = args.files
        with open(episodes, newline="") as f:
            rows = list(csv.DictReader(f))
        if not rows or list(rows[0].keys())[: len(HEADER)] != HEADER:
            fail(f"{episodes}: not a groundscope episodes.csv (header {HEADER})")
        # minigrid's registered levels end an episode when the instruction is satisfied;
        # rows of groundscope's done-action mode (`--done`, the paper's) would replay in the
        # wrong mode.
        done_rows = [r for r in rows if r.get("done_required") == "1"]
        if done_rows:
            r = done_rows[0]
            fail(f"{episodes}: {len(done_rows)} rows ran in the done-action mode (first: "
                 f"{r['checkpoint']} {r['level']} seed {r['level_seed']}); minigrid's "
                 "registered levels do not require 'done', so they cannot be replayed here: "
                 "evaluate without --done")
        if args.checkpoint is not None:
            rows = [r for r in rows if r["checkpoint"] == args.checkpoint]
            if not rows:
                fail(f"{episodes}: no rows of checkpoint {args.checkpoint!r}")

    out_rows = []
    envs: dict[str, gym.Env] = {}
    smallest_gap = np.inf
    for r in rows:
        level = r["level"]
        if level not in envs:
            if level not in gym.registry:
                fail(f"level {level!r} is not registered in minigrid")
            envs[level] = gym.make(level)
        outcome, gap = episode(graph, envs[level], int(r["level_seed"]))
        smallest_gap = min(smallest_gap, gap)
        out_rows.append({k: r[k] for k in HEADER[:5]} | outcome)

    with open(out_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=HEADER, lineterminator="\n")
        w.writeheader()
        w.writerows(out_rows)
    success = np.mean([int(r["success"]) for r in out_rows])
    if args.levels is None:
        same = sum(
            a["actions"] == b["actions"] and a["mission"] == b["mission"]
            for a, b in zip(rows, out_rows)
        )
        print(f"replayed {len(out_rows)} episodes; {same} take groundscope's actions exactly; "
              f"success {success:.3f}; smallest logit gap {smallest_gap:.3g}; wrote {out_path}")
    else:
        steps = sum(int(r["steps"]) for r in out_rows)
        print(f"ran {len(out_rows)} episodes ({steps} steps); success {success:.3f}; smallest "
              f"logit gap {smallest_gap:.3g}; wrote {out_path}")
    if smallest_gap < args.min_gap:
        print(f"error: a step's two largest logits are {smallest_gap:.3g} apart, under "
              f"--min-gap {args.min_gap:g}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
