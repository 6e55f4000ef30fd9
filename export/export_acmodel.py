#!/usr/bin/env python3
"""Export an rl-starter-files / torch-ac ``ACModel`` — image only, or with memory, text or
both — to an ONNX graph of groundscope's contract 1 (docs/onnx.md).

    python export/export_acmodel.py OUT.onnx [--status storage/MODEL/status.pt] [--level JSON|ID]

With ``--status`` the weights and the vocabulary come from an rl-starter-files ``status.pt``
(``model_state`` and ``vocab``, as ``scripts/train.py`` saves them); which parts the model
has is read from its weights: an ``LSTMCell`` memory (``memory_rnn``, trained with
recurrence > 1, ``--mem`` here) and a GRU over the mission (``text_rnn``, ``--text``).
Without it the model is a deterministic random initialisation (``torch.manual_seed(0)``)
with memory and text unless ``--no-memory`` / ``--no-text``, and a vocabulary of
groundscope's mission words numbered as rl-starter-files numbers words (0 is padding, then
in order of first use), which is not groundscope's own numbering.

The graph's inputs are ``image`` (B, 7, 7, 3) float32 (rl-starter-files feeds MiniGrid's
codes as floats), and where the model has them ``mission`` (B, L) int64 and ``memory``
(B, M) float32; its outputs ``logits`` (the log-probabilities of the model's
``Categorical``), ``value`` and, with memory, ``memory_out``. A model without text takes no
mission (its metadata has no vocabulary), one without memory no memory (``memory_size``
0). No maps: groundscope explains it by occlusion. ``--level`` is the level it was trained
on: a JSON level, or a registered id alone (``MiniGrid-DoorKey-5x5-v0``,
``BabyAI-GoToRedBallGrey-v0``), written ``{"babyai": ID}``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
from torch.distributions.categorical import Categorical

sys.path.insert(0, str(Path(__file__).resolve().parent))

import onnx_contract as oc  # noqa: E402

# --- ACModel of rl-starter-files (https://github.com/lcswillems/rl-starter-files, model.py),
# --- MIT License, Copyright (c) Lucas Willems. Reproduced as it stands, but for the base
# --- class torch_ac.RecurrentACModel (an empty interface) and this comment.


# Function from https://github.com/ikostrikov/pytorch-a2c-ppo-acktr/blob/master/model.py
def init_params(m):
    classname = m.__class__.__name__
    if classname.find("Linear") != -1:
        m.weight.data.normal_(0, 1)
        m.weight.data *= 1 / torch.sqrt(m.weight.data.pow(2).sum(1, keepdim=True))
        if m.bias is not None:
            m.bias.data.fill_(0)


class ACModel(nn.Module):
    recurrent = True

    def __init__(self, obs_space, action_space, use_memory=False, use_text=False):
        super().__init__()

        # Decide which components are enabled
        self.use_text = use_text
        self.use_memory = use_memory

        # Define image embedding
        self.image_conv = nn.Sequential(
            nn.Conv2d(3, 16, (2, 2)),
            nn.ReLU(),
            nn.MaxPool2d((2, 2)),
            nn.Conv2d(16, 32, (2, 2)),
            nn.ReLU(),
            nn.Conv2d(32, 64, (2, 2)),
            nn.ReLU()
        )
        n = obs_space["image"][0]
        m = obs_space["image"][1]
        self.image_embedding_size = ((n-1)//2-2)*((m-1)//2-2)*64

        # Define memory
        if self.use_memory:
            self.memory_rnn = nn.LSTMCell(self.image_embedding_size, self.semi_memory_size)

        # Define text embedding
        if self.use_text:
            self.word_embedding_size = 32
            self.word_embedding = nn.Embedding(obs_space["text"], self.word_embedding_size)
            self.text_embedding_size = 128
            self.text_rnn = nn.GRU(self.word_embedding_size, self.text_embedding_size, batch_first=True)

        # Resize image embedding
        self.embedding_size = self.semi_memory_size
        if self.use_text:
            self.embedding_size += self.text_embedding_size

        # Define actor's model
        self.actor = nn.Sequential(
            nn.Linear(self.embedding_size, 64),
            nn.Tanh(),
            nn.Linear(64, action_space.n)
        )

        # Define critic's model
        self.critic = nn.Sequential(
            nn.Linear(self.embedding_size, 64),
            nn.Tanh(),
            nn.Linear(64, 1)
        )

        # Initialize parameters correctly
        self.apply(init_params)

    @property
    def memory_size(self):
        return 2*self.semi_memory_size

    @property
    def semi_memory_size(self):
        return self.image_embedding_size

    def forward(self, obs, memory):
        x = obs.image.transpose(1, 3).transpose(2, 3)
        x = self.image_conv(x)
        x = x.reshape(x.shape[0], -1)

        if self.use_memory:
            hidden = (memory[:, :self.semi_memory_size], memory[:, self.semi_memory_size:])
            hidden = self.memory_rnn(x, hidden)
            embedding = hidden[0]
            memory = torch.cat(hidden, dim=1)
        else:
            embedding = x

        if self.use_text:
            embed_text = self._get_embed_text(obs.text)
            embedding = torch.cat((embedding, embed_text), dim=1)

        x = self.actor(embedding)
        dist = Categorical(logits=F.log_softmax(x, dim=1))

        x = self.critic(embedding)
        value = x.squeeze(1)

        return dist, value, memory

    def _get_embed_text(self, text):
        _, hidden = self.text_rnn(self.word_embedding(text))
        return hidden[-1]


# --- end of rl-starter-files' model.py


class ContractWrapper(nn.Module):
    """``ACModel.forward(obs, memory) → (dist, value, memory)`` with the contract's names:
    ``(image, mission, memory) → (logits, value, memory_out)``; ``logits`` are the
    distribution's own (normalised) logits, so their softmax is the policy. The subclasses
    below take only the inputs the model reads (the contract feeds inputs by name, and an
    export keeps only the parameters ``forward`` names)."""

    def __init__(self, model: ACModel):
        super().__init__()
        self.model = model

    def run(self, image, mission, memory):
        dist, value, memory_out = self.model(SimpleNamespace(image=image, text=mission), memory)
        return dist.logits, value, memory_out

    def forward(self, image, mission, memory):
        return self.run(image, mission, memory)


class MemoryWrapper(ContractWrapper):
    """A model with memory and no text: ``(image, memory) → (logits, value, memory_out)``."""

    def forward(self, image, memory):
        return self.run(image, None, memory)


class TextWrapper(ContractWrapper):
    """A model with text and no memory: ``(image, mission) → (logits, value)``."""

    def forward(self, image, mission):
        return self.run(image, mission, None)[:2]


class ImageWrapper(ContractWrapper):
    """rl-starter-files' default model, image only: ``image → (logits, value)``."""

    def forward(self, image):
        return self.run(image, None, None)[:2]


def wrapper(model: ACModel) -> ContractWrapper:
    """The wrapper of the inputs ``model`` reads."""
    cls = {
        (True, True): ContractWrapper,
        (True, False): MemoryWrapper,
        (False, True): TextWrapper,
        (False, False): ImageWrapper,
    }[(model.use_memory, model.use_text)]
    return cls(model).eval()


# rl-starter-files' obs_space for MiniGrid: a 7×7×3 image and a text vocabulary of 100 ids.
OBS_SPACE = {"image": (7, 7, 3), "text": 100}
N_ACTIONS = 7
# Words in the order rl-starter-files' Vocabulary would number them on groundscope's
# missions (ids from 1; 0 pads): deliberately not groundscope's own numbering.
RANDOM_VOCABULARY = [
    "<pad>", "go", "to", "the", "red", "key", "pick", "up", "a", "ball",
    "grey", "box", "purple", "yellow", "green", "blue",
]


def vocabulary_list(vocab: dict[str, int], size: int) -> list[str]:
    """rl-starter-files' ``{word: id}`` as the contract's list (index = id); unused ids get
    placeholder words that no mission holds."""
    words = [f"<unused{i}>" for i in range(max(size, max(vocab.values(), default=0) + 1))]
    words[0] = "<pad>"
    for w, i in vocab.items():
        words[int(i)] = w
    return words


def parts(model: ACModel) -> str:
    """What the model has beside the image, for its display name."""
    on = [p for p, o in (("memory", model.use_memory), ("text", model.use_text)) if o]
    return " + ".join(["image"] + on)


def build(
    status: str | None, memory: bool = True, text: bool = True
) -> tuple[ACModel, list[str] | None, str]:
    """The model in eval mode, its vocabulary (``None`` without text) and a display name.
    ``memory`` and ``text`` choose the parts of a random initialisation; a ``status.pt``'s
    weights say which parts it has."""
    torch.manual_seed(0)
    if status is None:
        model = ACModel(OBS_SPACE, SimpleNamespace(n=N_ACTIONS), use_memory=memory, use_text=text)
        name = "ACModel (random init, seed 0)"
        if not (memory and text):
            name = f"ACModel {parts(model)} (random init, seed 0)"
        return model.eval(), RANDOM_VOCABULARY if text else None, name
    st = torch.load(status, map_location="cpu", weights_only=False)
    state = st["model_state"]
    use_memory = "memory_rnn.weight_ih" in state
    use_text = "word_embedding.weight" in state
    n_actions = state["actor.2.weight"].shape[0]
    if n_actions != N_ACTIONS:
        raise SystemExit(f"error: {status}: the actor scores {n_actions} actions, not 7")
    obs_space = dict(OBS_SPACE)
    if use_text:
        obs_space["text"] = state["word_embedding.weight"].shape[0]
    model = ACModel(obs_space, SimpleNamespace(n=N_ACTIONS), use_memory=use_memory,
                    use_text=use_text)
    model.load_state_dict(state)
    vocabulary = None
    if use_text:
        vocab = st.get("vocab")
        if not vocab:
            raise SystemExit(f"error: {status} has no vocab (saved without a text observation?)")
        vocabulary = vocabulary_list(vocab, 0)
    return model.eval(), vocabulary, f"ACModel {parts(model)} ({Path(status).parent.name})"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="the ONNX file to write")
    ap.add_argument("--status", help="rl-starter-files status.pt (default: random init)")
    ap.add_argument(
        "--level",
        default=json.dumps(oc.DEFAULT_LEVEL),
        help="the level it was trained on: JSON, or a registered id alone (BabyAI's or "
        "MiniGrid's); default groundscope's default level",
    )
    ap.add_argument("--name", help="display name")
    ap.add_argument("--no-memory", action="store_true",
                    help="a random initialisation without memory (with --status: its weights say)")
    ap.add_argument("--no-text", action="store_true",
                    help="a random initialisation without text (with --status: its weights say)")
    ap.add_argument("--tolerance", type=float, default=1e-5)
    args = ap.parse_args()

    # The distribution's argument checks are Python branches on tensor values: off for tracing.
    Categorical.set_default_validate_args(False)
    model, vocabulary, name = build(args.status, not args.no_memory, not args.no_text)
    level = oc.level_arg(args.level)
    missing = [w for w in oc.MISSION_WORDS if w not in (vocabulary or [])]
    if vocabulary is not None and oc.paper_level(level) and missing:
        print(f"warning: the vocabulary lacks {missing}: groundscope refuses the paper's "
              "missions with them (give the level it was trained on with --level)",
              file=sys.stderr)
    module = wrapper(model)
    rng = np.random.default_rng(0)
    m = model.memory_size if model.use_memory else 0
    words = vocabulary or ["<pad>"]
    example = oc.random_feeds(rng, 2, 5, words, m, np.float32)
    example = {k: torch.from_numpy(example[k]) for k in oc.module_inputs(module, example)}
    outputs = ["logits", "value"] + (["memory_out"] if model.use_memory else [])
    props = oc.metadata(vocabulary, m, level, "image", args.name or name)
    oc.export(module, example, outputs, args.out, props, "groundscope export_acmodel.py")
    print(f"wrote {args.out} ({Path(args.out).stat().st_size / 1e6:.2f} MB), {name}")
    print(oc.describe(args.out))
    feeds = [
        oc.random_feeds(rng, b, l, words, m, np.float32)
        for b, l in [(1, 4), (2, 5), (3, 2), (5, 4), (8, 5), (4, 3)]
    ]
    if not oc.print_diffs(oc.compare(args.out, module, feeds), args.tolerance):
        print("error: the ONNX file differs from the PyTorch module", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
