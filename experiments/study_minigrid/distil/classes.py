#!/usr/bin/env python3
"""Grounding per class from `groundscope eval`'s report.md, as docs/studies/minigrid-agent.md
tabulates it: the ids where the class was scored, the pointing game's range and mean over them,
a uniform map's chance, and the paper's `acc`. The levels of several reports (one evaluation
split over processes) are pooled; with `--beside EARLIER.md`, that report's mean pointing beside.

    python3 experiments/study_minigrid/distil/classes.py REPORT.md [REPORT.md ...] [--beside EARLIER.md]
"""
import re
import sys

SECTIONS = {
    "object words": "## Object-word maps",
    "colour words": "## Colour-word maps",
    '"door"': '## "door" maps',
    '"goal"': '## "goal" maps',
    '"lava"': '## "lava" maps',
    '"opening"': '## "opening" maps',
    "`M` on the target": "## Combined map M",
}


def first_number(cell):
    return float(re.match(r"\s*([0-9.]+)", cell).group(1))


def scored(text, head):
    """(acc, pointing, chance) per level of one section, levels with no scored step left out."""
    out = []
    if head not in text:
        return out
    for line in text[text.index(head):].splitlines()[1:]:
        if line.startswith("## "):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        # checkpoint, level, grid, rooms, acc, acc_ng, acc_bs, acc_cmb, pointing, mass,
        # chance (acc · acc_ng · pointing and mass), evaluated steps, episodes without
        if len(cells) != 13 or not cells[11].isdigit() or int(cells[11]) == 0:
            continue
        out.append((first_number(cells[4]), first_number(cells[8]), float(cells[10].split("·")[-1])))
    return out


def main():
    args = sys.argv[1:]
    beside = None
    if "--beside" in args:
        i = args.index("--beside")
        beside = open(args[i + 1]).read()
        args = args[:i] + args[i + 2:]
    texts = [open(p).read() for p in args]
    extra = " | earlier mean" if beside else ""
    print(f"| class | ids | pointing | mean | chance | `acc` (mean){extra} |")
    print("|---|---|---|---|---|---|" + ("---|" if beside else ""))
    for name, head in SECTIONS.items():
        rows = [r for t in texts for r in scored(t, head)]
        if not rows:
            continue
        acc, pts, chance = zip(*rows)
        line = (f"| {name} | {len(rows)} | {min(pts):.2f}–{max(pts):.2f} | {sum(pts) / len(pts):.2f} "
                f"| {min(chance):.2f}–{max(chance):.2f} | {sum(acc) / len(acc):.3f} |")
        if beside:
            old = [p for _, p, _ in scored(beside, head)]
            line += f" {sum(old) / len(old):.2f} |" if old else " – |"
        print(line)


if __name__ == "__main__":
    main()
