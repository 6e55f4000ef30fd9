#!/usr/bin/env python3
"""Grounding per class from `groundscope eval`'s report.md, as docs/studies/minigrid-agent.md
tabulates it: the ids where the class was scored, the pointing game's range and mean over them,
a uniform map's chance, and the paper's `acc`. With a second report, its mean pointing beside.

    python3 experiments/study_minigrid/distil/classes.py REPORT.md [EARLIER_REPORT.md]
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
    texts = [open(p).read() for p in sys.argv[1:3]]
    earlier = " | earlier mean" if len(texts) > 1 else ""
    print(f"| class | ids | pointing | mean | chance | `acc` (mean){earlier} |")
    print("|---|---|---|---|---|---|" + ("---|" if earlier else ""))
    for name, head in SECTIONS.items():
        rows = scored(texts[0], head)
        if not rows:
            continue
        acc, pts, chance = zip(*rows)
        line = (f"| {name} | {len(rows)} | {min(pts):.2f}–{max(pts):.2f} | {sum(pts) / len(pts):.2f} "
                f"| {min(chance):.2f}–{max(chance):.2f} | {sum(acc) / len(acc):.3f} |")
        if earlier:
            old = [p for _, p, _ in scored(texts[1], head)]
            line += f" {sum(old) / len(old):.2f} |" if old else " – |"
        print(line)


if __name__ == "__main__":
    main()
