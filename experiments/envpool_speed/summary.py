#!/usr/bin/env python3
"""Per-level ratios from run.sh's JSON lines: groundscope's resets/s and steps/s over
EnvPool's (and minigrid's where measured), as a markdown table, the slowest ratio first.
Where a level was measured in several rounds (run.sh's ROUNDS), each side's median is used."""
import statistics
import json
import sys

rows = {}
for line in open(sys.argv[1]):
    line = line.strip()
    if not line.startswith("{"):
        continue
    r = json.loads(line)
    level = r["level"].split(" ")[0]
    side = {"env": "gs", "envpool-env": "ep", "minigrid-env": "mg"}[r["bench"]]
    rows.setdefault(level, {}).setdefault(side, []).append(r)

def median(runs):
    """One row per side: the median of each rate over the rounds (an error if any failed)."""
    if not runs:
        return None
    if any(r.get("error") for r in runs):
        return {"error": True}
    out = dict(runs[0])
    for key in ("resets_per_sec", "steps_per_sec"):
        out[key] = statistics.median(r[key] for r in runs)
    return out

def ratio(a, b, key):
    if a is None or b is None or a.get("error") or b.get("error"):
        return None
    return a[key] / b[key]

table = []
for level, r in rows.items():
    gs, ep, mg = (median(r.get(side, [])) for side in ("gs", "ep", "mg"))
    table.append((level, gs, ep, mg, ratio(gs, ep, "resets_per_sec"), ratio(gs, ep, "steps_per_sec"),
                  ratio(gs, mg, "resets_per_sec"), ratio(gs, mg, "steps_per_sec")))
table.sort(key=lambda t: (t[4] is None, t[4] or 0))
f = lambda x: "–" if x is None else f"{x:.1f}×"
k = lambda r, key: "–" if r is None or r.get("error") else f"{r[key] / 1000:.1f}k"
print("| level | groundscope resets/s | EnvPool resets/s | × EnvPool (resets) | groundscope steps/s | EnvPool steps/s | × EnvPool (steps) | × minigrid (resets) | × minigrid (steps) |")
print("|---|---|---|---|---|---|---|---|---|")
for level, gs, ep, mg, rr, sr, mr, ms in table:
    print(f"| {level} | {k(gs, 'resets_per_sec')} | {k(ep, 'resets_per_sec')} | {f(rr)} | {k(gs, 'steps_per_sec')} | {k(ep, 'steps_per_sec')} | {f(sr)} | {f(mr)} | {f(ms)} |")
done = [t for t in table if t[4] is not None]
if done:
    print()
    print(f"{len(done)} levels; resets: min {min(t[4] for t in done):.1f}×, "
          f"median {sorted(t[4] for t in done)[len(done) // 2]:.1f}× EnvPool; steps: min "
          f"{min(t[5] for t in done):.1f}×, median {sorted(t[5] for t in done)[len(done) // 2]:.1f}× EnvPool")
