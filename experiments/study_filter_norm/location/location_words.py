"""Where a location word's map goes, from `groundscope replay --trace` files (issue #64).

The paper's `acc` scores a location word on the object the whole description selects. This
reads the traces further: of the word's mass, how much lies on the referent, on other objects
(doors included) of the same description, on other objects, and on no object; and, at steps where objects lie
both inside and outside the half-plane the word names (minigrid's verifier: fixed at reset,
relative to the start pose), whether the map prefers the objects inside it. It also counts the
steps where the location word is needed at all: the referent and an object of the same type
and colour outside the half-plane both in view.

    python3 location_words.py TRACE_DIR > report.md
"""
import glob
import json
import os
import sys

TYPES = {"door": 4, "key": 5, "ball": 6, "box": 7}
OBJECT_CODES = set(TYPES.values())
COLOURS = {"red": 0, "green": 1, "blue": 2, "purple": 3, "yellow": 4, "grey": 5}
DIR_VEC = [(1, 0), (0, 1), (-1, 0), (0, -1)]
LOCATION_WORDS = {"left", "right", "front", "behind"}
VIEW = 7


def view_cells(step):
    """(i, j, grid x, grid y, type, colour) of each view cell; maps index [j][i], obs [i][j]."""
    ax, ay = step["agent_pos"]
    fx, fy = DIR_VEC[step["agent_dir"]]
    rx, ry = -fy, fx
    for i in range(VIEW):
        for j in range(VIEW):
            ty, co, _ = step["obs"][i][j]
            d, lat = VIEW - 1 - j, i - VIEW // 2
            yield i, j, ax + fx * d + rx * lat, ay + fy * d + ry * lat, ty, co


def in_half_plane(loc, start, start_dir, x, y):
    d1 = DIR_VEC[start_dir]
    d2 = (-d1[1], d1[0])
    v = (x - start[0], y - start[1])
    ahead = v[0] * d1[0] + v[1] * d1[1]
    side = v[0] * d2[0] + v[1] * d2[1]
    return {"left": side < 0, "right": side > 0, "front": ahead > 0, "behind": ahead < 0}[loc]


def main(trace_dir):
    classes = ["referent", "same description", "other objects", "no object"]
    maps = ["location word", "`M`"]
    mass = {(m, c): 0.0 for m in maps for c in classes}
    peak = {(m, c): 0 for m in maps for c in classes}
    steps = episodes = 0
    poses = ["at the start pose", "moved or turned"]
    half = {p: {"in": 0.0, "out": 0.0, "peak_in": 0, "share_in": 0.0, "steps": 0} for p in poses}
    needed = {"steps": 0, "episodes": set(), "m_on_referent": 0, "word_on_referent": 0}
    for path in sorted(glob.glob(os.path.join(trace_dir, "*.json"))):
        t = json.load(open(path))
        instr = t["initial_state"]["instr"]
        loc = instr.get("loc")
        if not loc:
            continue
        episodes += 1
        start, start_dir = t["initial_state"]["agent_pos"], t["initial_state"]["agent_dir"]
        word = max(i for i, w in enumerate(t["tokens"]) if w in LOCATION_WORDS)
        refs = {tuple(p) for p in instr["match_positions"]}
        for s in t["steps"]:
            cells = {}
            for i, j, x, y, ty, co in view_cells(s):
                if ty not in OBJECT_CODES:
                    c = "no object"
                else:
                    same = ty == TYPES[instr["type"]] and (
                        instr.get("color") is None or co == COLOURS[instr["color"]]
                    )
                    c = ("referent" if (x, y) in refs else "same description") if same else "other objects"
                cells[(i, j)] = (c, in_half_plane(loc, start, start_dir, x, y) if ty in OBJECT_CODES else None)
            kinds = [c for c, _ in cells.values()]
            word_map = s["attention"]["words"][word]["map"]
            maps_now = {"location word": word_map, "`M`": s["attention"]["combined"]}
            at = lambda m, k: m[k[1]][k[0]]
            if "referent" in kinds:
                steps += 1
                for name, m in maps_now.items():
                    for k, (c, _) in cells.items():
                        mass[(name, c)] += at(m, k)
                    peak[(name, cells[max(cells, key=lambda k: at(m, k))][0])] += 1
                if "same description" in kinds:
                    needed["steps"] += 1
                    needed["episodes"].add(path)
                    for name, key in (("`M`", "m_on_referent"), ("location word", "word_on_referent")):
                        m = maps_now[name]
                        best = max((k for k in cells if cells[k][0] in ("referent", "same description")), key=lambda k: at(m, k))
                        needed[key] += cells[best][0] == "referent"
            sides = [h for _, h in cells.values() if h is not None]
            if True in sides and False in sides:
                at_start = list(s["agent_pos"]) == list(start) and s["agent_dir"] == start_dir
                h = half[poses[0] if at_start else poses[1]]
                h["steps"] += 1
                for k, (c, side) in cells.items():
                    if side is not None:
                        h["in" if side else "out"] += at(word_map, k)
                objs = [k for k in cells if cells[k][1] is not None]
                h["peak_in"] += cells[max(objs, key=lambda k: at(word_map, k))][1]
                h["share_in"] += sum(cells[k][1] for k in objs) / len(objs)
    print(f"Traces: `{trace_dir}`; {episodes} episodes with a location word.\n")
    print(f"Steps with the referent in view: {steps}.\n")
    print("| map | " + " | ".join(f"mass on {c}" for c in classes) + " | " + " | ".join(f"peak on {c}" for c in classes) + " |")
    print("|---" * (1 + 2 * len(classes)) + "|")
    for m in maps:
        print(f"| {m} | " + " | ".join(f"{mass[(m, c)] / steps:.2f}" for c in classes) + " | "
              + " | ".join(f"{peak[(m, c)] / steps:.2f}" for c in classes) + " |")
    print("\nSteps with objects both inside and outside the named half-plane (the location word's map):\n")
    print("| agent | steps | mass on objects inside / outside | largest object cell inside | an object drawn at random |")
    print("|---|---|---|---|---|")
    for p in poses:
        h, n = half[p], max(half[p]["steps"], 1)
        print(f"| {p} | {h['steps']} | {h['in'] / n:.2f} / {h['out'] / n:.2f} | {h['peak_in'] / n:.2f} | {h['share_in'] / n:.2f} |")
    print()
    k = needed["steps"]
    print(f"Steps where the location word is needed (the referent and an object of the same description "
          f"in view): {k}, in {len(needed['episodes'])} episodes. Of the two, the largest cell is the "
          + (f"referent's at {needed['m_on_referent'] / k:.2f} of them for `M` and "
             f"{needed['word_on_referent'] / k:.2f} for the location word." if k else "referent's: no such steps."))


if __name__ == "__main__":
    main(sys.argv[1])
