#!/usr/bin/env python3
"""Prints the tables of issue #15's final-model runs from their kept logs (the recipe and
grounding studies, docs/studies/recipe-study.md and docs/studies/grounding-study.md).

usage: python3 experiments/tools/final_runs.py [--acc] [experiments/runs]

With --acc the accuracies are `acc` (the map on the object's own cell, the metric of the
issue's targets and of the grounding study from its fifth part on) instead of `acc_ng`.

`<model>_<recipe>_seed<N>` names the runs of another recipe (`attention_ent003_seed2`).

Reads `<model>_seed<N>_log.csv` and `<model>_seed<N>_eval_log.csv` as `groundscope train`
wrote them (15M frames, tracked held-out evaluation of 500 greedy episodes on level seeds
2^31 + e). The final 1,000-episode test set is not read here; the studies report it apart.
"""
import csv
import pathlib
import re
import statistics
import sys

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from recipe_study import BUDGET, first_at, rows, wall_hours  # noqa: E402


METRIC = "acc_ng"


def triple(r):
    # The baseline has no maps: its accuracy columns are empty.
    keys = ("greedy_success", f"object_{METRIC}", f"color_{METRIC}")
    return [float(r[k] or "nan") for k in keys]


def is_baseline(model):
    return model.split("_")[0] == "baseline"


def label(model):
    # `attention_ent003` (a recipe other than the chosen one) reads "attention `ent003`".
    base, _, tag = model.partition("_")
    return f"{base} `{tag}`" if tag else base


def fmt(v, model):
    if is_baseline(model):
        return f"{v[0]:.2f} / – / –"
    return " / ".join(f"{x:.2f}" for x in v)


def main():
    global METRIC
    args = sys.argv[1:]
    if args[:1] == ["--acc"]:
        METRIC, args = "acc", args[1:]
    root = pathlib.Path(args[0] if args else "experiments/runs")
    runs = {}
    for p in sorted(root.glob("*_seed*_log.csv")):
        m = re.fullmatch(r"(\w+?)_seed(\d+)_log\.csv", p.name)
        if not m or p.name.endswith("_eval_log.csv"):
            continue
        runs.setdefault(m.group(1), []).append((int(m.group(2)), p))
    print(
        f"| run | frames | to 90% / 95% / 99% | at 5M: success / object / colour `{METRIC}` "
        "| at the end | wall time |"
    )
    print("|---|---|---|---|---|---|")
    for model, seeds in sorted(runs.items()):
        at5s, ends, hours = [], [], []
        for seed, p in sorted(seeds):
            log = rows(p)
            ev = rows(p.with_name(p.name.replace("_log.csv", "_eval_log.csv")))
            at5 = triple([r for r in ev if int(r["frames"]) <= BUDGET][-1])
            end = triple(ev[-1])
            at5s.append(at5)
            ends.append(end)
            hours.append(wall_hours(log))
            reach = " / ".join(first_at(ev, x) for x in (0.90, 0.95, 0.99))
            print(
                f"| {label(model)} seed {seed} | {int(log[-1]['frames']) / 1e6:.2f}M | {reach} | "
                f"{fmt(at5, model)} | {fmt(end, model)} | {hours[-1]:.2f} h |"
            )
        if len(seeds) > 1:
            def mean_std(vs):
                cols = list(zip(*vs))
                return " / ".join(
                    f"{statistics.mean(c):.2f} ± {statistics.stdev(c):.2f}" for c in cols
                ) if not is_baseline(model) else (
                    f"{statistics.mean(cols[0]):.2f} ± {statistics.stdev(cols[0]):.2f} / – / –"
                )
            print(
                f"| **{label(model)}, mean ± std over {len(seeds)} seeds** | | | {mean_std(at5s)} | "
                f"{mean_std(ends)} | {statistics.mean(hours):.2f} h |"
            )


if __name__ == "__main__":
    main()
