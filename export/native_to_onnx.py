#!/usr/bin/env python3
"""Convert a native groundscope checkpoint to an ONNX graph of contract 1 (docs/onnx.md).

    python export/native_to_onnx.py assets/attention tests/fixtures/onnx/bundled_attention.onnx

CHECKPOINT is ``NAME`` of ``NAME.json`` + ``NAME.safetensors`` (a run directory's ``model``
works too). The graph goes through :class:`groundscope_torch.GroundscopeNet`, the PyTorch
replica of the native network; its metadata carries the checkpoint's vocabulary and level.
The script then runs the ONNX file with onnxruntime against the PyTorch module on random but
valid inputs (several batch sizes and mission lengths) and prints the largest absolute
difference of every output; with ``--check-trace`` it also replays groundscope traces
(``groundscope replay --checkpoint NAME --trace T.json``) through the ONNX graph, memory fed
back, and compares the actions (identical), maps and weights (within ``--tolerance``) and
probabilities and values (within ten times it) with the trace's.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))

import onnx_contract as oc  # noqa: E402
from groundscope_torch import GroundscopeNet, WithOverrides, output_names, tokenize  # noqa: E402


def check_traces(path: Path, traces: list[str], vocabulary: list[str]) -> dict[str, float]:
    """Replays groundscope traces through the ONNX file; the largest differences from the
    trace's own numbers (maps transposed from the graph's image layout to the trace's
    agent-up one)."""
    import onnxruntime as ort

    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    dtypes = {i.name: i.type for i in session.get_inputs()}
    img_dtype = np.float32 if dtypes["image"] == "tensor(float)" else np.int64
    names = [o.name for o in session.get_outputs()]
    memory_size = int(session.get_modelmeta().custom_metadata_map["groundscope.memory_size"])
    worst: dict[str, float] = {"probs": 0.0, "value": 0.0}
    for trace in traces:
        t = json.loads(Path(trace).read_text())
        mission = np.array([tokenize(t["mission"], vocabulary)], dtype=np.int64)
        memory = np.zeros((1, memory_size), dtype=np.float32)
        for step in t["steps"]:
            feeds = {
                "image": np.array([step["obs"]], dtype=img_dtype),
                "mission": mission,
                "memory": memory,
                # The intervention inputs, where the graph takes them, left at "no change".
                "combined_override": np.zeros((1, 7, 7), dtype=np.float32),
                "override_weight": np.zeros((1,), dtype=np.float32),
            }
            out = dict(zip(names, session.run(None, {k: feeds[k] for k in dtypes})))
            logits = out["logits"][0].astype(np.float64)
            probs = np.exp(logits - logits.max())
            probs /= probs.sum()
            if int(probs.argmax()) != step["action"] and t["mode"] == "greedy":
                print(f"  {trace} step {step['t']}: the ONNX file's action is "
                      f"{int(probs.argmax())}, the trace's {step['action']}")
                worst["actions differing"] = worst.get("actions differing", 0) + 1
            worst["probs"] = max(worst["probs"], float(np.abs(probs - step["probs"]).max()))
            worst["value"] = max(worst["value"], abs(float(out["value"][0]) - step["value"]))
            memory = out["memory_out"]
            att = step.get("attention")
            if att and "combined_map" in out:
                m = out["combined_map"][0].T  # [vx][vy] → [vy][vx]
                d = float(np.abs(m - np.array(att["combined"])).max())
                worst["M"] = max(worst.get("M", 0.0), d)
                for i, word in enumerate(att["words"]):
                    a = out["word_maps"][0, i].T
                    d = float(np.abs(a - np.array(word["map"])).max())
                    worst["A"] = max(worst.get("A", 0.0), d)
                    d = abs(float(out["word_weights"][0, i]) - word["weight"])
                    worst["w"] = max(worst.get("w", 0.0), d)
    return worst


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("checkpoint", help="native checkpoint NAME (NAME.json + NAME.safetensors)")
    ap.add_argument("out", help="the ONNX file to write")
    ap.add_argument("--name", help="display name (default: the checkpoint's file name)")
    ap.add_argument(
        "--image-dtype",
        choices=["int64", "float32"],
        default="int64",
        help="element type the graph declares for `image` (default int64)",
    )
    ap.add_argument(
        "--check-trace",
        nargs="*",
        default=[],
        metavar="TRACE",
        help="groundscope replay traces of this checkpoint to replay through the ONNX file",
    )
    ap.add_argument(
        "--no-overrides",
        action="store_true",
        help="leave out the intervention inputs combined_override and override_weight "
        "(an attention model takes them by default; docs/onnx.md#interventions)",
    )
    ap.add_argument("--tolerance", type=float, default=1e-5)
    args = ap.parse_args()

    torch.manual_seed(0)
    net, meta = GroundscopeNet.from_checkpoint(args.checkpoint)
    vocabulary = meta["vocabulary"]
    image_dtype = np.int64 if args.image_dtype == "int64" else np.float32
    rng = np.random.default_rng(0)
    example = oc.random_feeds(rng, 2, 5, vocabulary, net.memory_size, image_dtype)
    inputs = ["image", "mission", "memory"]
    if net.attention and not args.no_overrides:
        net = WithOverrides(net)
        inputs += ["combined_override", "override_weight"]
    example = {k: torch.from_numpy(example[k]) for k in inputs}
    name = args.name or Path(args.checkpoint).name
    props = oc.metadata(vocabulary, net.memory_size, meta["level"], "image", name)
    oc.export(net, example, output_names(net), args.out, props, "groundscope native_to_onnx.py")
    print(f"wrote {args.out} ({Path(args.out).stat().st_size / 1e6:.2f} MB), "
          f"{meta['model']['variant']} from {args.checkpoint}")
    print(oc.describe(args.out))

    feeds = [
        oc.random_feeds(rng, b, l, vocabulary, net.memory_size, image_dtype)
        for b, l in [(1, 4), (2, 5), (3, 2), (5, 4), (8, 5), (4, 3)]
    ]
    ok = oc.print_diffs(oc.compare(args.out, net, feeds), args.tolerance)
    if args.check_trace:
        worst = check_traces(Path(args.out), args.check_trace, vocabulary)
        print(f"  replayed {len(args.check_trace)} groundscope trace(s) through the ONNX file:")
        for k, d in worst.items():
            # Maps and weights within the tolerance; the policy and value, which go through
            # the LSTM's 784-long sums and logits up to ~20, within ten times it.
            tol = args.tolerance * (10 if k in ("probs", "value") else 1)
            tol = 0 if k == "actions differing" else tol
            ok &= d <= tol
            print(f"  max |onnx - trace| {k:13} {d:.3g}  {'ok' if d <= tol else f'ABOVE {tol:g}'}")
    if not ok:
        print("error: the ONNX file differs from the PyTorch module or from the traces",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
