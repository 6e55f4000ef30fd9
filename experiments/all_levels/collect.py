#!/usr/bin/env python3
"""Merges the chunked held-out evaluations of run.sh into one table over the 96 BabyAI ids.

Usage: collect.py OUT_DIR... > table.md   (each OUT_DIR an `eval --out` directory)
Writes a markdown table (one row per level: success mean ± std over the seeds, per checkpoint),
a summary of the counts the issue names (levels >= 0.90, > 0, KeyCorridor family), and each
checkpoint's grounding per word class over the levels where the class is scored.
"""
import csv
import sys
from collections import defaultdict

ORDER = ["bundled:babyai-grounded2", "bundled:babyai-grounded", "bundled:babyai", "bot"]


def main(dirs):
    success = defaultdict(dict)
    for d in dirs:
        with open(f"{d}/performance.csv") as f:
            for row in csv.DictReader(f):
                success[row["level"]][row["checkpoint"]] = (
                    float(row["success_mean"]),
                    float(row["success_std"]),
                )
    levels = sorted(success)
    ckpts = [c for c in ORDER if any(c in success[l] for l in levels)]
    print("| level | " + " | ".join(ckpts) + " |")
    print("|---|" + "---|" * len(ckpts))
    for l in levels:
        cells = []
        for c in ckpts:
            m, s = success[l].get(c, (float("nan"), 0.0))
            cells.append(f"{m:.3f} ± {s:.3f}")
        print(f"| {l} | " + " | ".join(cells) + " |")
    print()
    print(f"{len(levels)} levels.")
    print()
    print("| checkpoint | mean success | levels ≥ 0.90 | levels ≥ 0.50 | levels > 0 | KeyCorridor family (mean) |")
    print("|---|---|---|---|---|---|")
    for c in ckpts:
        vals = {l: success[l][c][0] for l in levels if c in success[l]}
        kc = [v for l, v in vals.items() if "KeyCorridor" in l]
        print(
            f"| {c} | {sum(vals.values()) / len(vals):.3f} | {sum(v >= 0.90 for v in vals.values())} "
            f"| {sum(v >= 0.50 for v in vals.values())} | {sum(v > 0 for v in vals.values())} "
            f"| {sum(kc) / max(len(kc), 1):.3f} ({', '.join(f'{v:.2f}' for v in kc)}) |"
        )


CLASSES = ["object", "color", "door", "location", "combined"]


def grounding(dirs):
    """Per checkpoint and class, the mean over the levels where the class is scored of acc,
    the pointing game and relevance mass, with a uniform map's pointing (chance) beside it."""
    by = defaultdict(lambda: defaultdict(lambda: defaultdict(list)))
    for d in dirs:
        with open(f"{d}/accuracy.csv") as f:
            for r in csv.DictReader(f):
                if r["word"] not in CLASSES or not r["pointing_mean"]:
                    continue
                if int(r["evaluated_steps"] or 0) == 0:
                    continue
                for k in ["acc_mean", "pointing_mean", "mass_mean", "chance_pointing"]:
                    by[r["checkpoint"]][r["word"]][k].append(float(r[k]))
    print()
    print("| checkpoint | " + " | ".join(f"{c}: acc / pointing (chance) / mass [levels]" for c in CLASSES) + " |")
    print("|---|" + "---|" * len(CLASSES))
    mean = lambda v: sum(v) / len(v) if v else float("nan")
    for c in ORDER:
        if c not in by:
            continue
        cells = []
        for k in CLASSES:
            f = by[c][k]
            cells.append(
                f"{mean(f['acc_mean']):.2f} / {mean(f['pointing_mean']):.2f} ({mean(f['chance_pointing']):.2f}) "
                f"/ {mean(f['mass_mean']):.2f} [{len(f['acc_mean'])}]"
            )
        print(f"| {c} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
    grounding(sys.argv[1:])
