#!/usr/bin/env python3
"""The big-room study's selection rule (docs/studies/big-rooms.md, section 1), computed from
one held-out `groundscope eval --first-seed 1000 --seeds 5 --episodes 100` directory.

For every attention checkpoint in the report: the shortfall D (sum of the distances to the
issue's targets) and the score Q, against the cell-by-cell mean success of the baselines
named with --baselines (default: every baseline in the report). Prints a table, and with
--json the terms of every checkpoint.

    python3 experiments/tools/big_room_score.py DIR [--baselines NAME,...] [--json F]
"""
import argparse
import csv
import gzip
import json
import os
import sys

WORDS = ["key", "ball", "box", "red", "green", "blue", "purple", "yellow", "grey"]
TIE = 0.01


def mean(stat):
    """A {mean, std} object's mean, or None."""
    return None if stat is None else stat.get("mean")


def load(directory):
    path = os.path.join(directory, "report.json")
    if os.path.exists(path):
        with open(path) as f:
            report = json.load(f)
    else:  # the copies kept in experiments/ are compressed
        with gzip.open(path + ".gz", "rt") as f:
            report = json.load(f)
    words = {}
    with open(os.path.join(directory, "words.csv"), newline="") as f:
        for row in csv.DictReader(f):
            if (int(row["size"]), int(row["objects"])) == (8, 4):
                words[(row["checkpoint"], row["word"])] = float(row["acc_mean"] or 0.0)
    return report, words


def terms(cells, name, base, words):
    """D's terms and Q for attention checkpoint `name` against baseline successes `base`."""
    mine = {(c["size"], c["objects"]): c for c in cells if c["checkpoint"] == name}
    a = {x: mean(c["success"]) or 0.0 for x, c in mine.items()}
    s8 = mine[(8, 4)]
    acc = s8["accuracy"]
    obj = mean(acc["object"]["acc"]) or 0.0
    col = mean(acc["color"]["acc"]) or 0.0
    m_cmb = mean(acc["combined"]["acc_cmb"]) or 0.0
    t = {
        "behind_baseline": sum(max(0.0, base[x] - a[x]) for x in base),
        "cells_behind": sum(1 for x in base if a[x] < base[x]),
        "s16n10": max(0.0, 0.90 - a[(16, 10)]),
        "s8n4": max(0.0, 0.99 - a[(8, 4)]),
        "object_acc": max(0.0, 0.90 - obj),
        "colour_acc": max(0.0, 0.85 - col),
        "m_acc_cmb": max(0.0, 0.80 - m_cmb),
        "words": sum(max(0.0, 0.70 - words.get((name, w), 0.0)) for w in WORDS),
    }
    d = sum(v for k, v in t.items() if k != "cells_behind")
    q = sum(a.values()) / len(a) + (obj + col + m_cmb) / 3.0
    return {
        "checkpoint": name,
        "D": d,
        "Q": q,
        "terms": t,
        "measured": {
            "mean_success": sum(a.values()) / len(a),
            "success_s8n4": a[(8, 4)],
            "success_s16n10": a[(16, 10)],
            "object_acc": obj,
            "colour_acc": col,
            "m_acc_cmb": m_cmb,
            "words": {w: words.get((name, w), 0.0) for w in WORDS},
        },
    }


def ranked(rows):
    """The rule's order: D lower by more than TIE first, else higher Q."""
    import functools

    def cmp(x, y):
        if abs(x["D"] - y["D"]) > TIE:
            return -1 if x["D"] < y["D"] else 1
        return -1 if x["Q"] > y["Q"] else (1 if x["Q"] < y["Q"] else 0)

    return sorted(rows, key=functools.cmp_to_key(cmp))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dir")
    p.add_argument("--baselines", help="comma-separated baseline checkpoint names")
    p.add_argument("--json", help="write every checkpoint's terms here")
    args = p.parse_args()
    report, words = load(args.dir)
    if report.get("first_seed", 0) < 1000:
        sys.exit(f"{args.dir}: first_seed {report.get('first_seed', 0)} < 1000: not held-out")
    cells = report["cells"]
    variants = {c["name"]: c["variant"] for c in report["checkpoints"]}
    bases = (
        args.baselines.split(",")
        if args.baselines
        else [n for n, v in variants.items() if v == "baseline"]
    )
    if not bases:
        sys.exit("no baseline in the report")
    base = {}
    for name in bases:
        for c in cells:
            if c["checkpoint"] == name:
                x = (c["size"], c["objects"])
                base[x] = base.get(x, 0.0) + (mean(c["success"]) or 0.0) / len(bases)
    rows = ranked(
        [terms(cells, n, base, words) for n, v in variants.items() if v == "attention"]
    )
    print(f"baseline: mean of {', '.join(bases)}")
    print("checkpoint | D | Q | cells behind (sum) | S16N10 | S8N4 | obj / col / M acc_cmb | words short")
    for r in rows:
        m, t = r["measured"], r["terms"]
        print(
            f"{r['checkpoint']} | {r['D']:.3f} | {r['Q']:.3f} | {t['cells_behind']} "
            f"({t['behind_baseline']:.3f}) | {m['success_s16n10']:.3f} | {m['success_s8n4']:.3f} | "
            f"{m['object_acc']:.3f} / {m['colour_acc']:.3f} / {m['m_acc_cmb']:.3f} | {t['words']:.3f}"
        )
    for name in bases:
        succ = [mean(c["success"]) or 0.0 for c in cells if c["checkpoint"] == name]
        print(f"baseline {name}: mean success over cells {sum(succ) / len(succ):.3f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"baselines": bases, "ranked": rows}, f, indent=1)


if __name__ == "__main__":
    main()
