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
   colour code is set only on cells whose type is ≥ 3 (objects, not unseen/empty/wall), with
   ``walls-objects`` also on walls (type 2);
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
lookups (``Gather``, :func:`lookup_conv`; no ``OneHot``), the LSTM step is an ``nn.LSTMCell``
(primitive ops), the text encoder one ``nn.GRU`` (a single ``GRU`` op, no ``sequence_lens``).
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
# The wall, which keeps its colour under colour_codes = walls-objects (src/policy/obs.rs).
WALL_TYPE = 2
# Smallest probability fed to ln (src/policy/attention.rs, TINY): 0 · ln 0 evaluates to 0.
TINY = 1e-30

# Defaults of fields a checkpoint's model.json may leave out (src/policy/config/mod.rs).
DEFAULTS = {
    "conv_kernel": 3,
    "filter_scale": 49,
    "colour_codes": "all",
    "word_temperature": 1.0,
    "key_kernel": None,
    "attend_words": "all",
}
# Token ids of the object and colour words (src/env/vocab.rs): ball, box, key = 7–9; red …
# grey = 11–16. attend_words = content weighs only these (src/policy/config/mod.rs, AttendWords).
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
        # The big-room study's part 5 (src/policy/config/mod.rs, search_query): not mirrored here
        # unless that recipe is chosen.
        raise ValueError("model.search_query = true is not supported by this export")
    if cfg.get("null_key"):
        # The big-room study's part 9 (src/policy/config/mod.rs, null_key): not mirrored here
        # unless that recipe is chosen.
        raise ValueError("model.null_key = true is not supported by this export")
    if cfg.get("key_context"):
        # The big-room study's part 11 (src/policy/config/mod.rs, key_context): not mirrored here
        # unless that recipe is chosen.
        raise ValueError("model.key_context = true is not supported by this export")
    if cfg.get("layout_path"):
        # Issue #64's unattended layout path (src/policy/config/mod.rs, layout_path): not mirrored
        # here unless that recipe is chosen.
        raise ValueError("model.layout_path = true is not supported by this export")
    if cfg.get("filter_norm"):
        # Issue #64's rescaled filter (src/policy/config/mod.rs, filter_norm): not mirrored here
        # unless that recipe is chosen.
        raise ValueError("model.filter_norm = true is not supported by this export")
    if cfg["colour_codes"] not in ("all", "objects", "walls-objects"):
        raise ValueError(
            f"model.colour_codes = {cfg['colour_codes']!r} must be all, objects or walls-objects"
        )
    return cfg


# The colour of a cell that ``colour_codes`` leaves out: a seventh colour, whose
# code contributes nothing (combo_table).
NO_COLOUR = 6
# A cell as one index: its type (11), colour (6 + NO_COLOUR) and state (3) together,
# ``(t·7 + c)·3 + s``; one more index stands for a cell outside the view (the conv's zero
# padding).
COMBOS = 11 * 7 * 3
OUTSIDE = COMBOS


class CellEncoder(nn.Module):
    """MiniGrid codes (B, 7, 7, 3) ``[vx][vy]`` → each cell's combined index (B, vy, vx),
    whole numbers as float32, ``0 … COMBOS − 1``: type ``min(t, 10)``, colour ``min(c, 5)``
    (``NO_COLOUR`` for one that ``colour_codes`` leaves out) and state
    ``min(s, 2)``."""

    def __init__(self, colour_codes: str):
        super().__init__()
        self.colour_codes = colour_codes

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        # Integer codes as floats (exact up to 2^24), cast to int64 once for the lookup:
        # tract's elementwise ops on int64 run many times slower than on float32. Clamped as
        # obs.rs's `min` does.
        x = image.to(torch.float32)
        t = torch.clamp(x[..., 0], 0.0, 10.0)
        c = torch.clamp(x[..., 1], 0.0, 5.0)
        s = torch.clamp(x[..., 2], 0.0, 2.0)
        if self.colour_codes != "all":
            coloured = t >= FIRST_COLOURED_TYPE
            if self.colour_codes == "walls-objects":
                coloured = coloured | (t == WALL_TYPE)
            c = torch.where(coloured, c, torch.full_like(c, float(NO_COLOUR)))
        combos = (t * 7.0 + c) * 3.0 + s  # (B, vx, vy)
        return combos.transpose(1, 2)  # (B, vy, vx): rows = vy (agent-up)


def combo_table(weight: torch.Tensor) -> torch.Tensor:
    """A conv's weight (K, 20, k, k) → one row per kernel offset and combined cell index,
    (k·k, COMBOS + 1, K): the sum of the weight columns of the cell's three codes (a colour
    of ``NO_COLOUR`` and a cell outside the view add nothing). A function of the weights alone,
    so the exporter folds it into one constant."""
    # Built as a list, so that the exporter sees one constant rather than the assignments.
    hot = [[0.0] * CELL_CODES for _ in range(COMBOS + 1)]
    for t in range(11):
        for c in range(7):
            for s in range(3):
                row = hot[(t * 7 + c) * 3 + s]
                row[t] = row[17 + s] = 1.0
                if c != NO_COLOUR:
                    row[11 + c] = 1.0
    k_out, _, ks, _ = weight.shape
    per_offset = weight.permute(2, 3, 1, 0).reshape(ks * ks, CELL_CODES, k_out)
    return torch.matmul(torch.tensor(hot), per_offset)


def lookup_conv(combos: torch.Tensor, conv: nn.Conv2d) -> torch.Tensor:
    """``Conv(one-hot codes)`` as table lookups, (B, 49, K), cells ``j = vy·7 + vx``, before the
    ReLU. The cross-correlation at a cell is the bias plus, for each kernel offset, the
    neighbour's row of :func:`combo_table` (the bias is folded into the centre's rows, which
    every cell reads once): one ``Gather`` of each cell's rows, one of its neighbours' and a
    sum over the k·k offsets. The same sums as ``conv`` over one-hot planes (in another
    order, ~1e-7); tract runs them several times faster than one-hot ``Equal``s and a padded
    convolution (docs/onnx.md#speed)."""
    # The module's own ints: the weight's shape is traced, and tests on it would warn.
    k_out, ks = conv.out_channels, conv.kernel_size[0]
    rows = COMBOS + 1
    p = ks // 2
    centre = p * ks + p
    none = torch.zeros(1, 1, k_out)
    after = ks * ks - 1 - centre
    bias = torch.cat([none] * centre + [conv.bias.reshape(1, 1, k_out)] + [none] * after)
    table = combo_table(conv.weight) + bias  # (k·k, rows, K)
    flat = combos.reshape(-1, N_CELLS)
    if ks == 1:
        # A 1×1 conv reads the cell alone: one row each.
        return F.embedding(flat.to(torch.int64), table[0])  # (B, 49, K)
    # Index N_CELLS stands for a cell outside the view: one column appended, no Pad. Each
    # cell's rows for all k·k offsets are looked up at once, then each cell picks its
    # neighbours' rows, offset by offset, with one constant index: the only cast is of the
    # cells' indices, and nothing is added to an index (each costs a slow pass in tract).
    flat = torch.cat([flat, torch.full_like(flat[:, :1], float(OUTSIDE))], dim=1)  # (B, 50)
    by_cell = table.transpose(0, 1).reshape(rows, -1)
    rows_of = F.embedding(flat.to(torch.int64), by_cell)  # (B, 50, k·k·K)
    rows_of = rows_of.reshape(-1, (N_CELLS + 1) * ks * ks, k_out)  # row n·k·k + offset

    def at(y: int, x: int) -> int:
        return y * VIEW + x if 0 <= y < VIEW and 0 <= x < VIEW else N_CELLS

    near = torch.tensor(
        [
            [
                at(vy + ky - p, vx + kx - p) * ks * ks + ky * ks + kx
                for ky in range(ks)
                for kx in range(ks)
            ]
            for vy in range(VIEW)
            for vx in range(VIEW)
        ]
    )  # (49, k·k): each cell's neighbour at each offset, and the offset's row
    return rows_of[:, near].sum(dim=2)  # (B, 49, K)


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
        combos = self.cells(image)  # (B, vy, vx)
        o = F.relu(lookup_conv(combos, self.conv))  # (B, 49, K), j = vy·7 + vx
        emb = self.word_emb(mission)  # (B, L, E)
        maps = None
        if self.attention:
            if self.key_conv is not None:
                o_key = F.relu(lookup_conv(combos, self.key_conv))
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
