#!/usr/bin/env python3
"""The 76-id held-out table of docs/studies/minigrid-agent.md from `groundscope eval`'s
performance.csv files: the bundled pair, a third attention model's success beside them,
rl-baselines3-zoo's mean reward (its benchmark.md, as issue #82 lists it) and
issue #82's pre-registered target per id, judged on the attention model.

    python3 experiments/study_minigrid/distil/table.py ATT.csv BASE.csv OTHER.csv "OTHER'S NAME"
"""
import csv, sys
att, base, old, old_name = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
ZOO = {"Empty-Random-5x5": 0.968, "DoorKey-5x5": 0.964, "Unlock": 0.963, "KeyCorridorS3R1": 0.949,
       "RedBlueDoors-6x6": 0.860, "PutNear-6x6-N2": 0.612, "FourRooms": 0.573, "GoToDoor-5x5": 0.525}
UNSOLVED = ["LockedRoom", "MultiRoom-N4-S5", "ObstructedMaze-2Dlh"]
SUCC = ["DoorKey-8x8", "LavaCrossingS9N1", "Dynamic-Obstacles-6x6", "MemoryS7", "Fetch-5x5-N2", "GoToObject-6x6-N2"]
def load(p, variant=None):
    out = {}
    for r in csv.DictReader(open(p)):
        if variant and r["variant"] != variant:
            continue
        lid = r["level"].removeprefix("MiniGrid-").removesuffix("-v0")
        out[lid] = r
    return out
A, B, O = load(att), load(base), load(old, "attention")
ids = sorted(set(A) | {"Playground"})
print(f"| id | `bundled:minigrid` success / reward | `bundled:minigrid-baseline` | {old_name} | zoo reward | target |")
print("|---|---|---|---|---|---|")
sa = sb = so = 0.0
met = []
for i in ids:
    if i == "Playground":
        print("| Playground | – (empty mission: no model reads it, minigrid never rewards it) | – | – | – |  |")
        continue
    a, b, o = A[i], B[i], O[i]
    f = lambda r: f"{float(r['success_mean']):.2f} ± {float(r['success_std']):.2f} / {float(r['reward_mean']):.3f}"
    ra, suca = float(a["reward_mean"]), float(a["success_mean"])
    sa += suca; sb += float(b["success_mean"]); so += float(o["success_mean"])
    zoo, tgt = "–", ""
    if i in ZOO:
        zoo = f"{ZOO[i]:.3f}"
        ok = ra >= ZOO[i]
        tgt = f"reward ≥ {ZOO[i]:.3f}: {'**met**' if ok else 'not met'}"
    elif i in UNSOLVED:
        zoo = "0.000 (unsolved)"
        ok = ra > 0
        tgt = f"reward > 0: {'**met**' if ok else 'not met'}"
    elif i in SUCC:
        ok = suca >= 0.90
        tgt = f"success ≥ 0.90: {'**met**' if ok else 'not met'}"
    else:
        ok = None
    if ok:
        met.append(i)
    print(f"| {i} | {f(a)} | {f(b)} | {float(o['success_mean']):.2f} | {zoo} | {tgt} |")
n = len(ids) - 1
print(f"| mean of {n} | {sa/n:.3f} | {sb/n:.3f} | {so/n:.3f} | | |")
print("met:", met, file=sys.stderr)
