#!/usr/bin/env python3
"""Export the attention model of the PyTorch reference (``../shared/tools/torch-reference``)
to an ONNX graph of groundscope's contract 1 (docs/onnx.md), with its maps as outputs.

    python export/export_torch_reference.py OUT.onnx --model-py ../shared/tools/torch-reference/model.py \\
        [--weights STATE_DICT.pt] [--level JSON]

The reference's ``ACModel(baseline=False)`` (its own ``model.py``, passed by path since it
lives outside the repository) is built with ``torch.manual_seed(0)`` (or loads a state dict
with ``--weights``). Its ``forward(image, text, memory)`` returns ``(dist, value, memory)``
only, so :class:`MapsWrapper` runs the same computation with the model's own layers and also
returns the per-word maps ``A`` (B, L, 7, 7), the word weights ``w`` (B, L) and the combined
map ``M`` (B, 7, 7). The script checks that the wrapper gives the model's own policy, value and
memory, then that onnxruntime gives the wrapper's outputs.

The reference differs from groundscope's native net: it feeds the three integer codes as
float channels to a 3×3 convolution over ``image.permute(0, 3, 1, 2)``, whose spatial axes
are (vx, vy) — so its maps come out in the ``image`` layout ``[vx][vy]``, the contract's
default — and its filter is ``F = Õ·M`` (no factor 49). Its vocabulary is ``train_ppo.py``'s
fixed ``WORDS``; it trained on ``BabyAI-GoToLocalS8N4-v0`` (go to, no done action, the
colour always named), the default ``--level``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
from torch.distributions.categorical import Categorical

sys.path.insert(0, str(Path(__file__).resolve().parent))

import onnx_contract as oc  # noqa: E402

# train_ppo.py's fixed vocabulary (index = token id; 0 pads, 1 is its unknown word).
WORDS = ["<pad>", "<unk>", "go", "to", "the", "a", "red", "green", "blue", "purple", "yellow",
         "grey", "ball", "box", "key", "door", "object", "pick", "up", "open", "put", "next",
         "and", "then", "after", "you"]
# BabyAI-GoToLocalS8N4-v0: one 8×8 room, 4 objects, "go to" missions naming type and colour,
# no done action.
REFERENCE_LEVEL = {
    "room_size": 8,
    "n_objects": 4,
    "tasks": "goto",
    "done_required": False,
    "color_optional": False,
}


def load_reference(model_py: str):
    """The reference's ``model`` module, imported from its path."""
    spec = importlib.util.spec_from_file_location("torch_reference_model", model_py)
    if spec is None or spec.loader is None:
        raise SystemExit(f"error: cannot import {model_py}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class MapsWrapper(nn.Module):
    """The reference model's forward, step for step with its own layers, returning the
    contract's outputs: logits, value, memory_out, word_maps, word_weights, combined_map."""

    def __init__(self, model: nn.Module, ref):
        super().__init__()
        self.model = model
        self.hid = ref.HID
        self.d = ref.D

    def forward(self, image, mission, memory):
        m_ = self.model
        b = image.shape[0]
        x = F.relu(m_.conv(image.permute(0, 3, 1, 2)))  # (B, 16, vx, vy)
        o = x.flatten(2).transpose(1, 2)  # (B, 49, 16), cell vx·7 + vy
        g = m_.emb(mission)
        scores = m_.q(g) @ m_.k(o).transpose(1, 2) / math.sqrt(self.d)
        a = scores.softmax(-1)
        h = -(a * a.clamp_min(1e-12).log()).sum(-1)
        w = (-h).masked_fill(mission == 0, float("-inf")).softmax(-1)
        m = (w.unsqueeze(-1) * a).sum(1)
        o = o * m.unsqueeze(-1)
        hx, cx = m_.lstm(o.flatten(1), (memory[:, : self.hid], memory[:, self.hid :]))
        _, th = m_.gru(g)
        emb = torch.cat([hx, th[-1]], 1)
        logits = F.log_softmax(m_.actor(emb), dim=1)
        value = m_.critic(emb).squeeze(1)
        # Cells are already [vx][vy]: the image layout, no transpose.
        l = a.shape[1]
        return (logits, value, torch.cat([hx, cx], 1),
                a.reshape(b, l, 7, 7), w, m.reshape(b, 7, 7))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="the ONNX file to write")
    ap.add_argument("--model-py", required=True, help="the torch reference's model.py")
    ap.add_argument("--weights", help="a state dict of the reference's ACModel (default: seed 0)")
    ap.add_argument("--level", default=json.dumps(REFERENCE_LEVEL),
                    help="JSON of the level it was trained on (default: GoToLocalS8N4)")
    ap.add_argument("--name", default="torch reference attention (random init, seed 0)")
    ap.add_argument("--tolerance", type=float, default=1e-5)
    args = ap.parse_args()

    Categorical.set_default_validate_args(False)
    ref = load_reference(args.model_py)
    torch.manual_seed(0)
    model = ref.ACModel(baseline=False)
    if args.weights:
        model.load_state_dict(torch.load(args.weights, map_location="cpu"))
    model.eval()
    wrapper = MapsWrapper(model, ref).eval()
    m = model.memory_size
    rng = np.random.default_rng(0)

    # The wrapper must be the model: same policy, value and memory on random inputs.
    worst = 0.0
    for b, l in [(1, 4), (3, 5), (6, 2)]:
        f = oc.random_feeds(rng, b, l, WORDS, m, np.float32)
        img, mis, mem = (torch.from_numpy(f[k]) for k in ("image", "mission", "memory"))
        with torch.no_grad():
            dist, value, mem_out = model(img, mis, mem)
            out = wrapper(img, mis, mem)
        for x, y in ((dist.probs, out[0].softmax(-1)), (value, out[1]), (mem_out, out[2])):
            worst = max(worst, float((x - y).abs().max()))
    print(f"wrapper vs the reference's own forward: max |diff| {worst:.3g}")
    if worst > 1e-6:
        print("error: the wrapper does not compute the reference model", file=sys.stderr)
        return 1

    example = oc.random_feeds(rng, 2, 5, WORDS, m, np.float32)
    example = {k: torch.from_numpy(example[k]) for k in ("image", "mission", "memory")}
    props = oc.metadata(WORDS, m, json.loads(args.level), "image", args.name)
    oc.export(wrapper, example,
              ["logits", "value", "memory_out", "word_maps", "word_weights", "combined_map"],
              args.out, props, "groundscope export_torch_reference.py")
    print(f"wrote {args.out} ({Path(args.out).stat().st_size / 1e6:.2f} MB), "
          f"from {args.model_py}")
    print(oc.describe(args.out))
    feeds = [
        oc.random_feeds(rng, b, l, WORDS, m, np.float32)
        for b, l in [(1, 4), (2, 5), (3, 2), (5, 4), (8, 5), (4, 3)]
    ]
    if not oc.print_diffs(oc.compare(args.out, wrapper, feeds), args.tolerance):
        print("error: the ONNX file differs from the PyTorch module", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
