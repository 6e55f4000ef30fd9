#!/usr/bin/env python3
"""Scores runs of issue #15's grounding study by the rule fixed in advance
(docs/studies/grounding-study.md).

usage: python3 experiments/tools/grounding_score.py [--acc] [--until FRAMES] VALIDATE.csv...

Each CSV holds `groundscope validate --episodes 500 --out F` rows for one run's whole-million
snapshots (the tracked held-out levels). A run's score is its best snapshot from 5M frames on,
among those with greedy success >= 0.97, by min(object acc_ng / 0.90, colour acc_ng / 0.80).
With --acc the same on `acc` (the map's value on the target's own cell, the metric of the
issue's targets), the score of the study's fifth part on (fixed 2026-11-23 20:43 UTC).
With --until F only snapshots at or below F frames count (the `paper` seeds' 10M budget,
fixed 2026-11-24 00:02 UTC, and the runs they are compared with).
"""
import csv
import sys

args = sys.argv[1:]
metric = 'acc_ng'
until = float('inf')
while args and args[0] in ('--acc', '--until'):
    if args[0] == '--acc':
        metric, args = 'acc', args[1:]
    else:
        until, args = int(args[1]), args[2:]
for f in args:
    rows = [r for r in csv.DictReader(open(f)) if 5_000_000 <= int(r['frames']) <= until]
    ok = [r for r in rows if float(r['greedy_success']) >= 0.97]
    obj, col = (lambda r: float(r['object_' + metric])), (lambda r: float(r['color_' + metric]))
    sc = [(min(obj(r) / 0.90, col(r) / 0.80), r) for r in ok]
    if not sc:
        print(f, 'no snapshot with greedy >= 0.97'); continue
    s, r = max(sc, key=lambda x: x[0])
    print(f"{f}: score ({metric}) {s:.3f} at {int(r['frames'])/1e6:.2f}M (greedy {float(r['greedy_success']):.3f}, object {obj(r):.3f}, colour {col(r):.3f}); {len(ok)} of {len(rows)} snapshots eligible")
