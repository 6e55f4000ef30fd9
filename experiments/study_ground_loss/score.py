#!/usr/bin/env python3
"""The grounding loss study's rule (README.md), from each run's eval/ (or any eval output
directories given): per recipe, the mean validation success over levels and, per scored class,
the mean over the levels where it occurs of acc, the pointing game and relevance mass, with a
uniform map's pointing beside it; then the recipe the rule chooses. Standard library only.

    python3 experiments/study_ground_loss/score.py studies/ground-loss/runs/*/eval
"""
import csv
import sys
from collections import defaultdict
from pathlib import Path

CLASSES = ["object", "color", "door", "location", "combined"]
MARGIN = 0.03


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def score(d):
    perf = rows(d / "performance.csv")
    succ = [float(r["success_mean"]) for r in perf]
    by = defaultdict(lambda: defaultdict(list))
    for r in rows(d / "accuracy.csv"):
        if r["word"] not in CLASSES or not r["pointing_mean"]:
            continue
        if int(r["evaluated_steps"] or 0) == 0:
            continue
        for k in ["acc_mean", "pointing_mean", "mass_mean", "chance_pointing", "region_mean", "chance_region"]:
            if r.get(k):
                by[r["word"]][k].append(float(r[k]))
    mean = lambda v: sum(v) / len(v) if v else float("nan")
    return mean(succ), len(succ), {c: {k: mean(v) for k, v in by[c].items()} | {"levels": len(by[c]["acc_mean"])} for c in CLASSES}


def main():
    dirs = [Path(a) for a in sys.argv[1:]]
    res = {}
    for d in dirs:
        name = d.parent.name if d.name == "eval" else d.name
        res[name] = score(d)
    print("| run | success | " + " | ".join(f"{c} acc / pointing (chance) / mass" for c in CLASSES) + " | mean pointing |")
    print("|---|---|" + "---|" * (len(CLASSES) + 1))
    for name, (s, n, cls) in sorted(res.items()):
        cells = []
        for c in CLASSES:
            f = cls[c]
            cells.append(f"{f.get('acc_mean', float('nan')):.3f} / {f.get('pointing_mean', float('nan')):.3f} ({f.get('chance_pointing', float('nan')):.3f}) / {f.get('mass_mean', float('nan')):.3f}")
        mp = sum(cls[c].get("pointing_mean", 0.0) for c in CLASSES) / len(CLASSES)
        print(f"| {name} | {s:.3f} ({n} levels) | " + " | ".join(cells) + f" | {mp:.3f} |")
    control = [k for k in res if k.startswith("control")]
    if control:
        floor = res[control[0]][0] - MARGIN
        ok = {k: v for k, v in res.items() if v[0] >= floor}
        best = max(ok, key=lambda k: sum(ok[k][2][c].get("pointing_mean", 0.0) for c in CLASSES))
        print(f"\nrule: success ≥ {floor:.3f} (control − {MARGIN}); qualifying: {sorted(ok)}; chosen: {best}")


if __name__ == "__main__":
    main()
