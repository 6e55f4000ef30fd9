"""groundscope's native policy network in PyTorch, built from a native checkpoint.

A native checkpoint is ``NAME.safetensors`` (weights, PyTorch-style names) plus ``NAME.json``
(``model`` sizes, ``vocabulary``, ``level``). :class:`GroundscopeNet` computes exactly what
the Rust network computes (``src/policy/obs.rs``, ``model.rs``, ``attention.rs``), but reads
its inputs as the ONNX contract of docs/onnx.md gives them:

* ``image`` (B, 7, 7, 3): MiniGrid's ``obs["image"]``, ``image[b][vx][vy][c]``;
* ``mission`` (B, L) int64 token ids of the checkpoint's vocabulary, no padding;
* ``memory`` (B, 2·H): ``cat(h, c)`` of the LSTM (zeros at an episode start).

and returns ``logits`` (B, 7), ``value`` (B,), ``memory_out`` (B, 2·H) and, for the attention
variant, ``word_maps`` (B, L, 7, 7), ``word_weights`` (B, L) and ``combined_map`` (B, 7, 7),
the maps in the ``image`` axis order ``[vx][vy]`` (the contract's default ``map_layout``).

The network, step by step (DESIGN.md §1):

1. each view cell is one-hot encoded over 20 codes: object type ``min(t, 10)``, then
   ``11 + min(colour, 5)``, then ``17 + min(state, 2)``; with ``colour_codes: objects`` the
   colour code is set only on cells whose type is ≥ 3 (objects, not unseen/empty/wall);
2. the codes are laid out agent-up, ``[vy][vx]`` (the transpose of MiniGrid's image), and
   ``Õ = ReLU(Conv(codes))``, a ``conv_kernel``×``conv_kernel`` cross-correlation with
   padding ``conv_kernel // 2`` over (vy, vx): the weight ``encoder.conv.weight`` [K, 20, k, k]
   is a PyTorch ``Conv2d`` weight as it stands; cells are then flattened ``j = vy·7 + vx``;
3. ``Q = g̃ W_qᵀ``, ``Kc = Õ_key W_kᵀ`` (no biases), with ``Õ_key = ReLU(Conv_key(codes))``
   when ``key_kernel`` is set (``encoder.key_conv.*``), else ``Õ`` itself (computed as
   ``(Q W_k / √d_k) Õ_keyᵀ``, the same scores regrouped);
4. ``A = softmax(Q Kcᵀ / √d_k)`` over the 49 cells; ``H = −Σ A ln max(A, 1e-30)``;
   ``w = softmax(−H / T)`` (T = ``word_temperature``, default 1; over the object and colour
   words only with ``attend_words = content``); ``M = Σ_i w_i A_i``;
5. ``F = s · M ⊙ Õ`` (s = ``filter_scale``, default 49), flattened cell-major then channel;
   the baseline variant skips 3–5 and passes ``Õ`` flattened;
6. an LSTM cell (PyTorch's equations, gates i, f, g, o) over ``F``; a GRU (gates r, z, n)
   over the mission's word embeddings, its last state;
7. ``z = cat(h, gru)``; actor ``Linear → tanh → Linear`` (7 logits), critic likewise (value).

Only ops that tract runs are used: the convolution over one-hot codes is written as table
lookups (``Gather``, :func:`lookup_conv`; no ``OneHot``), the LSTM step is an ``nn.LSTMCell`` (primitive ops), the text encoder one
``nn.GRU`` (a single ``GRU`` op, no ``sequence_lens``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import torch
import torch.nn as nn
import torch.nn.functional as F

VIEW = 7
N_CELLS = VIEW * VIEW
CELL_CODES = 20
N_ACTIONS = 7
# Object types below this one (unseen 0, empty 1, wall 2) carry no colour of their own under
# colour_codes = objects (src/policy/obs.rs, FIRST_COLOURED_TYPE).
FIRST_COLOURED_TYPE = 3
# Smallest probability fed to ln (src/policy/attention.rs, TINY): 0 · ln 0 evaluates to 0.
TINY = 1e-30

# Defaults of fields a checkpoint's model.json may leave out (src/policy/config.rs).
DEFAULTS = {
    "conv_kernel": 3,
    "filter_scale": 49,
    "colour_codes": "all",
    "word_temperature": 1.0,
    "key_kernel": None,
    "attend_words": "all",
}
# Token ids of the object and colour words (src/env/vocab.rs): ball, box, key = 7–9; red …
# grey = 11–16. attend_words = content weighs only these (src/policy/config.rs, AttendWords).
CONTENT_IDS = ((7, 9), (11, 16))


def load_native(checkpoint: str | Path) -> tuple[dict, dict[str, torch.Tensor]]:
    """Reads ``CHECKPOINT.json`` and ``CHECKPOINT.safetensors`` (``CHECKPOINT`` with or
    without either suffix): the JSON document and the named weights."""
    from safetensors.torch import load_file

    base = Path(checkpoint)
    if base.suffix in (".json", ".safetensors"):
        base = base.with_suffix("")
    meta = json.loads(base.with_suffix(".json").read_text())
    weights = load_file(str(base.with_suffix(".safetensors")))
    return meta, weights


def model_config(meta: dict) -> dict:
    """The checkpoint's ``model`` section with every optional field defaulted."""
    cfg = dict(DEFAULTS)
    cfg.update(meta["model"])
    if cfg["variant"] not in ("attention", "baseline"):
        raise ValueError(f"model.variant = {cfg['variant']!r} must be attention or baseline")
    if cfg.get("search_query"):
        # The big-room study's part 5 (src/policy/config.rs, search_query): not mirrored here
        # unless that recipe is chosen.
        raise ValueError("model.search_query = true is not supported by this export")
    if cfg.get("null_key"):
        # The big-room study's part 9 (src/policy/config.rs, null_key): not mirrored here
        # unless that recipe is chosen.
        raise ValueError("model.null_key = true is not supported by this export")
    if cfg.get("key_context"):
        # The big-room study's part 11 (src/policy/config.rs, key_context): not mirrored here
        # unless that recipe is chosen.
        raise ValueError("model.key_context = true is not supported by this export")
    if cfg["colour_codes"] not in ("all", "objects"):
        raise ValueError(f"model.colour_codes = {cfg['colour_codes']!r} must be all or objects")
    return cfg


# A cell code that contributes nothing: outside the view (the conv's zero padding) and, under
# colour_codes = objects, the colour of a cell that is not an object.
NO_CODE = CELL_CODES


class CellEncoder(nn.Module):
    """MiniGrid codes (B, 7, 7, 3) ``[vx][vy]`` → each cell's three one-hot positions
    (B, vy, vx, 3), whole numbers as float32: type ``0–10``, colour ``11–16``, state ``17–19``
    (``NO_CODE`` for a colour that ``colour_codes = objects`` leaves out)."""

    def __init__(self, colour_codes: str):
        super().__init__()
        self.objects_only = colour_codes == "objects"

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        # Integer codes as floats (exact up to 2^24): clamp as obs.rs's `min` does.
        x = image.to(torch.float32)
        t = torch.clamp(x[..., 0], 0.0, 10.0)
        c = torch.clamp(x[..., 1], 0.0, 5.0) + 11.0
        s = torch.clamp(x[..., 2], 0.0, 2.0) + 17.0
        if self.objects_only:
            c = torch.where(t >= FIRST_COLOURED_TYPE, c, torch.full_like(c, float(NO_CODE)))
        idx = torch.stack([t, c, s], dim=-1)  # (B, vx, vy, 3)
        return idx.permute(0, 2, 1, 3)  # (B, vy, vx, 3): rows = vy (agent-up)


def lookup_conv(idx: torch.Tensor, conv: nn.Conv2d) -> torch.Tensor:
    """``Conv(one-hot codes)`` as table lookups, (B, 49, K), cells ``j = vy·7 + vx``, before the
    ReLU. A cell's one-hot planes have three ones, so the cross-correlation at a cell is the
    bias plus, for each kernel offset and each of the neighbour's three codes, one column of
    the weight: a table of ``k·k·21`` rows (the 21st of each offset zero, for ``NO_CODE``)
    gathered by ``offset·21 + code``. The same sums as ``conv`` over one-hot planes (in another
    order, ~1e-7); tract runs a ``Gather`` and a sum several times faster than the one-hot
    ``Equal``s and the padded convolution (docs/onnx.md#speed)."""
    k_out, _, ks, _ = conv.weight.shape
    p = ks // 2
    rows = CELL_CODES + 1
    table = conv.weight.permute(2, 3, 1, 0).reshape(ks * ks, CELL_CODES, k_out)
    table = F.pad(table, (0, 0, 0, 1)).reshape(ks * ks * rows, k_out)
    # Padded and offset as floats (whole numbers, exact), cast once: tract's Pad does not take
    # the int64 codes of a cast.
    padded = F.pad(idx, (0, 0, p, p, p, p), value=float(NO_CODE))  # (B, 7 + 2p, 7 + 2p, 3)
    windows = [
        padded[:, ky : ky + VIEW, kx : kx + VIEW, :] + float((ky * ks + kx) * rows)
        for ky in range(ks)
        for kx in range(ks)
    ]
    which = torch.cat(windows, dim=-1).to(torch.int64)  # (B, 7, 7, 3·k·k)
    o = F.embedding(which, table).sum(dim=3) + conv.bias  # (B, 7, 7, K)
    return o.reshape(o.shape[0], N_CELLS, k_out)


class GroundscopeNet(nn.Module):
    """The native network (attention or baseline variant) with the ONNX contract's inputs and
    outputs; build it with :meth:`from_checkpoint`."""

    def __init__(self, cfg: dict, vocab_size: int):
        super().__init__()
        self.cfg = cfg
        k, ks = cfg["conv_channels"], cfg["conv_kernel"]
        self.attention = cfg["variant"] == "attention"
        self.hidden = cfg["lstm_hidden"]
        self.cells = CellEncoder(cfg["colour_codes"])
        self.conv = nn.Conv2d(CELL_CODES, k, ks, padding=ks // 2)
        self.key_conv = None
        if self.attention and cfg["key_kernel"] is not None:
            kk = cfg["key_kernel"]
            self.key_conv = nn.Conv2d(CELL_CODES, k, kk, padding=kk // 2)
        self.word_emb = nn.Embedding(vocab_size, cfg["word_dim"])
        if self.attention:
            self.q = nn.Linear(cfg["word_dim"], cfg["key_dim"], bias=False)
            self.k = nn.Linear(k, cfg["key_dim"], bias=False)
        self.lstm = nn.LSTMCell(N_CELLS * k, cfg["lstm_hidden"])
        self.gru = nn.GRU(cfg["word_dim"], cfg["gru_hidden"], batch_first=True)
        z = cfg["lstm_hidden"] + cfg["gru_hidden"]
        h = cfg["head_hidden"]
        self.actor = nn.Sequential(nn.Linear(z, h), nn.Tanh(), nn.Linear(h, N_ACTIONS))
        self.critic = nn.Sequential(nn.Linear(z, h), nn.Tanh(), nn.Linear(h, 1))

    @property
    def memory_size(self) -> int:
        return 2 * self.hidden

    @classmethod
    def from_checkpoint(cls, checkpoint: str | Path) -> tuple["GroundscopeNet", dict]:
        """The network with the checkpoint's weights (eval mode) and the checkpoint's JSON."""
        meta, w = load_native(checkpoint)
        cfg = model_config(meta)
        net = cls(cfg, w["word_emb.weight"].shape[0])
        names = {
            "encoder.conv.weight": "conv.weight",
            "encoder.conv.bias": "conv.bias",
            "word_emb.weight": "word_emb.weight",
        }
        if net.key_conv is not None:
            names["encoder.key_conv.weight"] = "key_conv.weight"
            names["encoder.key_conv.bias"] = "key_conv.bias"
        if net.attention:
            names["attention.q.weight"] = "q.weight"
            names["attention.k.weight"] = "k.weight"
        for rnn in ("lstm", "gru"):
            for p in ("weight_ih", "weight_hh", "bias_ih", "bias_hh"):
                # The native LSTM is one cell: LSTMCell's parameters have no `_l0` suffix.
                names[f"{rnn}.{p}_l0"] = f"{rnn}.{p}" if rnn == "lstm" else f"{rnn}.{p}_l0"
        for head in ("actor", "critic"):
            for layer in ("0", "2"):
                for p in ("weight", "bias"):
                    names[f"{head}.{layer}.{p}"] = f"{head}.{layer}.{p}"
        state = {}
        for theirs, ours in names.items():
            if theirs not in w:
                raise KeyError(f"checkpoint {checkpoint} has no tensor {theirs}")
            state[ours] = w[theirs]
        net.load_state_dict(state, strict=True)
        return net.eval(), meta

    def forward(self, image: torch.Tensor, mission: torch.Tensor, memory: torch.Tensor):
        return self.step(image, mission, memory)

    def step(
        self,
        image: torch.Tensor,
        mission: torch.Tensor,
        memory: torch.Tensor,
        combined_override: torch.Tensor | None = None,
        override_weight: torch.Tensor | None = None,
    ):
        """:meth:`forward`, with the contract's optional intervention inputs: ``M`` becomes
        ``(1 − α)·M + α·combined_override`` (α = ``override_weight``, (B,); the map (B, 7, 7)
        in the image layout ``[vx][vy]``) before the filter; the outputs show that ``M``."""
        b = image.shape[0]
        codes = self.cells(image)  # (B, vy, vx, 3) one-hot positions
        o = F.relu(lookup_conv(codes, self.conv))  # (B, 49, K), j = vy·7 + vx
        emb = self.word_emb(mission)  # (B, L, E)
        maps = None
        if self.attention:
            if self.key_conv is not None:
                o_key = F.relu(lookup_conv(codes, self.key_conv))
            else:
                o_key = o
            q = self.q(emb)  # (B, L, d_k)
            d_k = self.cfg["key_dim"]
            # Q Kcᵀ / √d_k with Kc = Õ_key W_kᵀ, regrouped as (Q W_k / √d_k) Õ_keyᵀ (the native
            # training path's keyed queries, attention.rs): the bracket reads the mission
            # alone, so groundscope computes it once per mission (docs/onnx.md#speed).
            keyed = torch.matmul(q, self.k.weight) / math.sqrt(d_k)  # (B, L, K)
            a = torch.softmax(torch.matmul(keyed, o_key.transpose(1, 2)), dim=-1)
            h = -(a * torch.log(torch.clamp(a, TINY, 1.0))).sum(-1)  # (B, L)
            t = float(self.cfg["word_temperature"])
            neg_h = -h if t == 1.0 else -h / t
            if self.cfg["attend_words"] == "content":
                keep = torch.zeros_like(mission, dtype=torch.bool)
                for lo, hi in CONTENT_IDS:
                    keep = keep | ((mission >= lo) & (mission <= hi))
                # A mission without a content word keeps every word, as in Rust.
                keep = keep | ~keep.any(dim=-1, keepdim=True)
                neg_h = neg_h.masked_fill(~keep, -1e9)
            w = torch.softmax(neg_h, dim=-1)  # (B, L)
            m = torch.matmul(w.unsqueeze(1), a).squeeze(1)  # (B, 49)
            if combined_override is not None and override_weight is not None:
                alpha = override_weight.unsqueeze(1)  # (B, 1)
                given = combined_override.transpose(1, 2).reshape(b, N_CELLS)  # → [vy][vx]
                m = (1.0 - alpha) * m + alpha * given
            x = o * (m * float(self.cfg["filter_scale"])).unsqueeze(2)  # (B, 49, K)
            maps = (a, w, m)
        else:
            x = o
        hx, cx = self.lstm(
            x.reshape(b, -1), (memory[:, : self.hidden], memory[:, self.hidden :])
        )
        # An explicit zero state of the batch's size (the exporter's own default works too,
        # but warns that it might not).
        h0 = torch.zeros(1, b, self.gru.hidden_size, dtype=emb.dtype)
        _, text = self.gru(emb, h0)
        z = torch.cat([hx, text[-1]], dim=1)
        logits = self.actor(z)
        value = self.critic(z).squeeze(1)
        memory_out = torch.cat([hx, cx], dim=1)
        if maps is None:
            return logits, value, memory_out
        a, w, m = maps
        l = a.shape[1]
        # Agent-up [vy][vx] → the image's axis order [vx][vy] (the contract's default layout).
        word_maps = a.reshape(b, l, VIEW, VIEW).transpose(2, 3)
        combined = m.reshape(b, VIEW, VIEW).transpose(1, 2)
        return logits, value, memory_out, word_maps, w, combined


class WithOverrides(nn.Module):
    """A :class:`GroundscopeNet` that also takes the contract's intervention inputs
    ``combined_override`` and ``override_weight`` (docs/onnx.md#interventions), so that
    groundscope can set ``M`` (faithfulness interventions, closed-loop probes)."""

    def __init__(self, net: GroundscopeNet):
        super().__init__()
        if not net.attention:
            raise ValueError("only a model with maps can take combined_override")
        self.net = net
        self.attention = True
        self.memory_size = net.memory_size

    def forward(
        self,
        image: torch.Tensor,
        mission: torch.Tensor,
        memory: torch.Tensor,
        combined_override: torch.Tensor,
        override_weight: torch.Tensor,
    ):
        return self.net.step(image, mission, memory, combined_override, override_weight)


def output_names(net: GroundscopeNet) -> list[str]:
    """The contract's names of :meth:`GroundscopeNet.forward`'s outputs, in order."""
    names = ["logits", "value", "memory_out"]
    if net.attention:
        names += ["word_maps", "word_weights", "combined_map"]
    return names


def tokenize(mission: str, vocabulary: list[str]) -> list[int]:
    """The contract's tokenisation: lowercase, split on whitespace, look each word up."""
    ids = []
    for word in mission.lower().split():
        if word not in vocabulary:
            raise KeyError(f"the vocabulary has no word {word!r}")
        ids.append(vocabulary.index(word))
    return ids
