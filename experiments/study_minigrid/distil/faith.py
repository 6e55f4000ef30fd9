#!/usr/bin/env python3
"""The faithfulness table of docs/studies/minigrid-agent.md from `groundscope faithfulness`'s
faithfulness.md: per id, steering `M` to a distractor and a uniform `M` (closed loop) beside
the unmodified episodes, the map's pointing game, and issue #82's two thresholds.

    python3 experiments/study_minigrid/distil/faith.py FAITHFULNESS.md
"""
import re, sys
t = open(sys.argv[1]).read()
print("| id | steering `M` → distractor (unmodified) | uniform `M` → success (unmodified) | map pointing (uniform map) | verdict |")
print("|---|---|---|---|---|")
for sec in re.split(r"\n## ", t)[1:]:
    m = re.match(r"(.*?) \(attention, MiniGrid-(.*?)-v0\)", sec)
    if not m: continue
    lid = m.group(2)
    def row(name):
        r = re.search(r"\| " + re.escape(name) + r" \| (.*?) \| (.*?) \|", sec)
        return r.group(1), r.group(2)
    sv, sc = row("closed loop, steered: success / distractor")
    uv, uc = row("closed loop, uniform: success / distractor")
    pm = (re.search(r"\| (object) map: pointing game \| (.*?) \| (.*?) \|", sec)
          or re.search(r"\| (door) map: pointing game \| (.*?) \| (.*?) \|", sec)
          or re.search(r"\| (\w+) map: pointing game \| (.*?) \| (.*?) \|", sec))
    pv, pc = f"{pm.group(1)} " + pm.group(2), pm.group(3)
    steer = sv.split("/")[1].split("±")[0].strip(); unm_d = sc.split("/")[1].split("±")[0].strip()
    uni = uv.split("/")[0].split("±")[0].strip(); unm_s = uc.split("/")[0].replace("unmodified", "").split("±")[0].strip()
    ok1 = float(steer) >= 0.80; ok2 = float(uni) <= 0.20
    verdict = ("steering met" if ok1 else "steering not met") + "; " + ("uniform met" if ok2 else "uniform not met")
    print(f"| {lid} | {steer} ({unm_d}) | {uni} ({unm_s}) | {pv.split('±')[0].strip()} ({pc.split('±')[0].strip()}) | {verdict} |")
