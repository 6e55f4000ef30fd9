#!/usr/bin/env python3
"""Write groundscope's contract metadata (docs/onnx.md) into an ONNX file you exported
yourself, or into a sidecar ``NAME.onnx.json`` beside it.

    python export/add_metadata.py my_agent.onnx --vocabulary vocab.json --memory-size 128 \\
        [--level '{"room_size": 8, "n_objects": 4, "tasks": "both", "done_required": true,
                   "color_optional": true}' | --level MiniGrid-DoorKey-5x5-v0]
        [--map-layout image|agent-up] [--name NAME] [--sidecar]

``--vocabulary`` is a JSON file holding either a list of words (index = token id) or an
rl-starter-files ``{word: id}`` dictionary; a graph that reads no mission (no ``mission``
input) needs none. ``--memory-size`` is M; a graph without memory (no ``memory`` input, no
``memory_out`` output) has none (0, the default then). ``--level`` is a JSON level or a
registered id alone (BabyAI's or MiniGrid's), written ``{"babyai": ID}``. Without
``--sidecar`` the file is rewritten in place with ``groundscope.*`` keys in its
``metadata_props``; with it, ``my_agent.onnx.json`` is written (keys without the prefix) and
the ONNX file is left alone. The script then checks the graph's inputs and outputs against the
contract and says what is missing.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import onnx

sys.path.insert(0, str(Path(__file__).resolve().parent))

import onnx_contract as oc  # noqa: E402


def read_vocabulary(path: str) -> list[str]:
    data = json.loads(Path(path).read_text())
    if isinstance(data, list):
        return [str(w) for w in data]
    if isinstance(data, dict):
        words = [f"<unused{i}>" for i in range(max(data.values(), default=0) + 1)]
        words[0] = "<pad>"
        for w, i in data.items():
            words[int(i)] = w
        return words
    raise SystemExit(f"error: {path}: a vocabulary is a JSON list or {{word: id}} object")


def check_names(model: onnx.ModelProto) -> list[str]:
    """What the graph lacks of the contract (empty when it has everything)."""
    return oc.check_graph(model)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("onnx_file")
    ap.add_argument("--vocabulary", help="JSON list of words or {word: id} (needed when the "
                    "graph takes a mission)")
    ap.add_argument("--memory-size", type=int, help="M, the memory's width (needed when the "
                    "graph has memory; 0 without)")
    ap.add_argument("--level", default=json.dumps(oc.DEFAULT_LEVEL),
                    help="JSON level, or a registered id alone (BabyAI's or MiniGrid's)")
    ap.add_argument("--map-layout", choices=["image", "agent-up"], default="image")
    ap.add_argument("--name", help="display name")
    ap.add_argument("--sidecar", action="store_true", help="write NAME.onnx.json instead")
    args = ap.parse_args()

    model = onnx.load(args.onnx_file)
    takes_mission, has_memory = oc.reads(model)
    level = oc.level_arg(args.level)
    if args.vocabulary is None and takes_mission:
        raise SystemExit(f"error: {args.onnx_file} takes a mission: give --vocabulary")
    vocabulary = None if args.vocabulary is None else read_vocabulary(args.vocabulary)
    if args.memory_size is None and has_memory:
        raise SystemExit(f"error: {args.onnx_file} has memory: give --memory-size")
    memory_size = args.memory_size or 0
    if not has_memory and memory_size:
        raise SystemExit(f"error: {args.onnx_file} has no memory input: --memory-size must be 0")
    missing = [w for w in oc.MISSION_WORDS if w not in (vocabulary or [])]
    if takes_mission and oc.paper_level(level) and missing:
        print(f"warning: the vocabulary lacks {missing}: groundscope refuses missions with them",
              file=sys.stderr)
    props = oc.metadata(vocabulary, memory_size, level, args.map_layout, args.name)
    if args.sidecar:
        sidecar = Path(args.onnx_file + ".json")
        # The same keys without the prefix; lists, objects and numbers as JSON values
        # (groundscope also reads them as the strings the protobuf would hold).
        plain = {k[len(oc.PREFIX):]: v for k, v in props.items()}
        if vocabulary is not None:
            plain["vocabulary"] = vocabulary
        plain["memory_size"] = memory_size
        plain["level"] = level
        sidecar.write_text(json.dumps(plain, indent=2) + "\n")
        print(f"wrote {sidecar}")
    else:
        oc.set_metadata(model, props)
        onnx.save(model, args.onnx_file)
        print(f"wrote the metadata into {args.onnx_file}")
    for p in check_names(model):
        print(f"warning: {args.onnx_file}: {p} (docs/onnx.md)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
