#!/usr/bin/env python3
"""Prints the recipe study's table (issue #15, docs/studies/recipe-study.md) from its run logs.

usage: python3 experiments/tools/recipe_study.py [experiments/recipe_study]

Every run directory holds the `log.csv` and `eval_log.csv` that `groundscope train` wrote,
cut at the study's budget of 5M frames. Everything comes from the tracked held-out evaluation
(500 greedy episodes on level seeds 2^31 + e); the final test set is never read.
"""
import csv
import pathlib
import sys

BUDGET = 5_001_216  # the first whole update past 5M frames of 2,048


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def wall_hours(log):
    # elapsed_secs restarts with every resumed segment; sum each segment's last value.
    total, last = 0.0, 0.0
    for r in log:
        e = float(r["elapsed_secs"])
        if e < last:
            total += last
        last = e
    return (total + last) / 3600


def first_at(ev, level):
    for r in ev:
        if float(r["greedy_success"]) >= level:
            return f"{int(r['frames']) / 1e6:.2f}M"
    return "not reached"


def cell(r):
    def f(k):
        return f"{float(r[k]):.2f}" if r.get(k) else "–"
    return f"{f('greedy_success')} / {f('object_acc_ng')} / {f('color_acc_ng')}"


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "experiments/recipe_study")
    print("| run | frames | to 90% | to 95% | best greedy (at) | at 5M: success / object / colour `acc_ng` | wall time |")
    print("|---|---|---|---|---|---|---|")
    for d in sorted(p for p in root.iterdir() if p.is_dir()):
        log = rows(d / "log.csv")
        ev = rows(d / "eval_log.csv")
        end = int(log[-1]["frames"])
        at5 = [r for r in ev if int(r["frames"]) <= BUDGET][-1]
        best = max(ev, key=lambda r: float(r["greedy_success"]))
        print(
            f"| `{d.name}` | {end / 1e6:.2f}M | {first_at(ev, 0.90)} | {first_at(ev, 0.95)} | "
            f"{float(best['greedy_success']):.3f} ({int(best['frames']) / 1e6:.2f}M) | "
            f"{cell(at5)} ({int(at5['frames']) / 1e6:.2f}M) | {wall_hours(log):.2f} h |"
        )


if __name__ == "__main__":
    main()
