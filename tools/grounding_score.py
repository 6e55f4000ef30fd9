#!/usr/bin/env python3
"""Scores runs of issue #15's grounding study by the rule README fixed in advance.

usage: python3 tools/grounding_score.py VALIDATE.csv...

Each CSV holds `groundscope validate --episodes 500 --out F` rows for one run's whole-million
snapshots (the tracked held-out levels). A run's score is its best snapshot from 5M frames on,
among those with greedy success >= 0.97, by min(object acc_ng / 0.90, colour acc_ng / 0.80).
"""
import csv
import sys

for f in sys.argv[1:]:
    rows = [r for r in csv.DictReader(open(f)) if int(r['frames']) >= 5_000_000]
    ok = [r for r in rows if float(r['greedy_success']) >= 0.97]
    sc = [(min(float(r['object_acc_ng'])/0.90, float(r['color_acc_ng'])/0.80), r) for r in ok]
    if not sc:
        print(f, 'no snapshot with greedy >= 0.97'); continue
    s, r = max(sc, key=lambda x: x[0])
    print(f"{f}: score {s:.3f} at {int(r['frames'])/1e6:.2f}M (greedy {float(r['greedy_success']):.3f}, object {float(r['object_acc_ng']):.3f}, colour {float(r['color_acc_ng']):.3f}); {len(ok)} of {len(rows)} snapshots eligible")
