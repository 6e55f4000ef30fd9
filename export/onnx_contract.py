"""groundscope's ONNX model contract, version 1 (docs/onnx.md): names, metadata, export and
checks shared by the export scripts of this folder."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import onnx

try:
    import torch
except ModuleNotFoundError:
    # make_bad_fixtures.py builds its graphs with onnx's helpers alone: it runs without
    # PyTorch; the exporters, which need it, fail on their first use of `torch`.
    torch = None
else:
    # Exports and checks are small: one thread keeps them off the cores of anything else.
    torch.set_num_threads(1)

CONTRACT = "1"
OPSET = 17
PREFIX = "groundscope."
# Inputs the contract names and the outputs it requires / shows. Only ``image`` is required:
# ``mission`` where the model reads one (a model without text reads none), ``memory`` in and
# ``memory_out`` out where it has memory (both or neither); ``direction`` and the override
# pair where the model takes them.
INPUTS = ("image", "direction", "mission", "memory", "combined_override", "override_weight")
REQUIRED_INPUTS = ("image",)
STATE_INPUTS = ("mission", "memory")
REQUIRED_OUTPUTS = ("logits", "value")
MEMORY_OUTPUT = "memory_out"
OPTIONAL_OUTPUTS = ("word_maps", "word_weights", "combined_map")
# The level fields of the paper's own levels; a level naming a registered id in ``babyai``
# (BabyAI's or MiniGrid's) may leave them out.
PAPER_LEVEL_FIELDS = ("room_size", "n_objects", "tasks", "done_required", "color_optional")
# Which axes of each named tensor are dynamic: B ("batch") everywhere, L ("words") on the
# mission and the per-word outputs.
DYNAMIC_AXES = {
    "image": {0: "batch"},
    "direction": {0: "batch"},
    "mission": {0: "batch", 1: "words"},
    "memory": {0: "batch"},
    "combined_override": {0: "batch"},
    "override_weight": {0: "batch"},
    "logits": {0: "batch"},
    "value": {0: "batch"},
    "memory_out": {0: "batch"},
    "word_maps": {0: "batch", 1: "words"},
    "word_weights": {0: "batch", 1: "words"},
    "combined_map": {0: "batch"},
}
# groundscope's own vocabulary (src/env/vocab.rs): index = token id, 0 = padding.
GROUNDSCOPE_VOCABULARY = [
    "<pad>", "a", "the", "go", "to", "pick", "up", "ball", "box", "key", "object", "red",
    "green", "blue", "purple", "yellow", "grey", "in", "front", "of", "you", "behind", "on",
    "your", "left", "right",
]
# The words groundscope's missions use ("go to the red key", "pick up a ball", ...).
MISSION_WORDS = [
    "a", "the", "go", "to", "pick", "up", "ball", "box", "key",
    "red", "green", "blue", "purple", "yellow", "grey",
]
# The paper's level, groundscope's default (src/env/level.rs).
DEFAULT_LEVEL = {
    "room_size": 8,
    "n_objects": 4,
    "tasks": "both",
    "done_required": True,
    "color_optional": True,
}
# Some groundscope missions, for checks (every one of them tokenises in MISSION_WORDS).
MISSIONS = [
    "go to the red key",
    "pick up a ball",
    "go to a grey box",
    "pick up the purple ball",
    "go to the key",
    "pick up a yellow box",
]


def level_arg(text: str) -> dict:
    """A ``--level`` argument: a JSON level, or a registered id alone (BabyAI's or MiniGrid's,
    ``MiniGrid-DoorKey-5x5-v0``), which is ``{"babyai": ID}``."""
    text = text.strip()
    if text.startswith("{"):
        return json.loads(text)
    return {"babyai": text}


def paper_level(level: dict) -> bool:
    """Whether ``level`` is the paper's (no registered id), whose missions use every word of
    ``MISSION_WORDS``."""
    return not level.get("babyai")


def metadata(
    vocabulary: list[str] | None,
    memory_size: int,
    level: dict,
    map_layout: str = "image",
    name: str | None = None,
) -> dict[str, str]:
    """The contract's ``metadata_props`` (keys with the ``groundscope.`` prefix).
    ``vocabulary`` may be ``None`` for a graph that reads no mission (the key is then left
    out); ``memory_size`` is 0 for a graph without memory."""
    if map_layout not in ("image", "agent-up"):
        raise ValueError(f"map_layout {map_layout!r} must be image or agent-up")
    if paper_level(level):
        missing = [f for f in PAPER_LEVEL_FIELDS if f not in level]
        if missing:
            raise ValueError(f"level {level}: the paper's level needs {missing} "
                             "(or name a registered id in 'babyai')")
    props = {
        "contract": CONTRACT,
        "memory_size": str(int(memory_size)),
        "level": json.dumps(level),
        "map_layout": map_layout,
    }
    if vocabulary is not None:
        props = {"contract": CONTRACT, "vocabulary": json.dumps(vocabulary), **props}
    if name is not None:
        props["name"] = name
    return {PREFIX + k: v for k, v in props.items()}


def set_metadata(model: onnx.ModelProto, props: dict[str, str]) -> None:
    """Sets (replaces) the given ``metadata_props`` of ``model``."""
    keep = [p for p in model.metadata_props if p.key not in props]
    del model.metadata_props[:]
    model.metadata_props.extend(keep)
    for k, v in props.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = k, v


def export(
    module: torch.nn.Module,
    example: dict[str, torch.Tensor],
    output_names: list[str],
    path: str | Path,
    props: dict[str, str],
    producer: str,
) -> onnx.ModelProto:
    """Exports ``module`` (called with ``example``'s tensors as positional arguments, in
    order) to ``path`` with the contract's input and output names, dynamic B and L, opset 17,
    the classic exporter; then writes ``props`` into its metadata and checks the file."""
    module.eval()
    names = list(example)
    args = tuple(example[n] for n in names)
    axes = {n: DYNAMIC_AXES[n] for n in names + list(output_names)}
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with torch.no_grad(), warnings.catch_warnings():
        # torch warns that a GRU exported at batch > 1 with its default initial state may
        # fail at other batch sizes; the state it writes follows the batch (Shape →
        # ConstantOfShape), and every export here is checked at batch sizes 1 to 8.
        warnings.filterwarnings("ignore", message="Exporting a model to ONNX with a batch_size")
        torch.onnx.export(
            module,
            args,
            str(path),
            input_names=names,
            output_names=list(output_names),
            dynamic_axes=axes,
            opset_version=OPSET,
            do_constant_folding=True,
            dynamo=False,
        )
    model = onnx.load(str(path))
    model.producer_name = producer
    model.doc_string = "groundscope ONNX model contract 1 (docs/onnx.md)"
    set_metadata(model, props)
    onnx.checker.check_model(model, full_check=True)
    onnx.save(model, str(path))
    return model


def random_images(rng: np.random.Generator, batch: int) -> np.ndarray:
    """Valid MiniGrid views (B, 7, 7, 3), ``[vx][vy]``: mostly floor and walls with a few
    objects, one unseen corner, the agent's cell empty; integer codes."""
    img = np.zeros((batch, 7, 7, 3), dtype=np.int64)
    img[..., 0] = rng.choice([1, 1, 1, 2], size=(batch, 7, 7))
    img[..., 1] = np.where(img[..., 0] == 2, 5, 0)
    for b in range(batch):
        for _ in range(rng.integers(1, 6)):
            vx, vy = rng.integers(0, 7, size=2)
            img[b, vx, vy] = [rng.integers(4, 11), rng.integers(0, 6), rng.integers(0, 3)]
        # Unseen cells behind a wall, as MiniGrid's visibility sweep leaves them.
        img[b, : rng.integers(0, 3), : rng.integers(0, 4)] = 0
        img[b, 3, 6] = [1, 0, 0]
    return img


def random_feeds(
    rng: np.random.Generator,
    batch: int,
    words: int,
    vocabulary: list[str],
    memory_size: int,
    image_dtype: np.dtype,
) -> dict[str, np.ndarray]:
    """Random but valid contract inputs: views, missions of ``words`` words drawn from the
    mission words, small random memory."""
    ids = [vocabulary.index(w) for w in MISSION_WORDS if w in vocabulary]
    if not ids:
        # A vocabulary of none of the paper's words (or none at all: a graph that reads no
        # mission): any of its own ids, else 0.
        ids = list(range(1, len(vocabulary))) or [0]
    return {
        "image": random_images(rng, batch).astype(image_dtype),
        "direction": rng.integers(0, 4, size=batch).astype(np.int64),
        "mission": rng.choice(ids, size=(batch, words)).astype(np.int64),
        "memory": (0.5 * rng.standard_normal((batch, memory_size))).astype(np.float32),
        # Maps that sum to 1, and a mix of rows left alone (0), set (1) and blended.
        "combined_override": (lambda m: (m / m.sum(axis=(1, 2), keepdims=True)).astype(np.float32))(
            rng.random((batch, 7, 7))
        ),
        "override_weight": rng.choice([0.0, 1.0, 0.5], size=batch).astype(np.float32),
    }


def compare(
    path: str | Path,
    module: torch.nn.Module,
    feeds_list: list[dict[str, np.ndarray]],
) -> dict[str, tuple[float, float]]:
    """Runs the ONNX file with onnxruntime and ``module`` on each feed; for every output (and
    ``probs``, the softmax of ``logits``) the largest absolute difference over all feeds and
    the largest difference scaled by ``max(1, |torch value|)`` (float32 rounding grows with
    the magnitude: logits of 20 differ by a few 1e-6 in the last bits)."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    opts.inter_op_num_threads = 1
    session = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
    graph_inputs = [i.name for i in session.get_inputs()]
    out_names = [o.name for o in session.get_outputs()]
    worst = {n: (0.0, 0.0) for n in out_names + ["probs"]}

    def update(n: str, g: np.ndarray, w: np.ndarray) -> None:
        if g.shape != w.shape:
            raise AssertionError(f"output {n}: onnx shape {g.shape}, torch {w.shape}")
        d = np.abs(g.astype(np.float64) - w.astype(np.float64))
        scaled = d / np.maximum(1.0, np.abs(w))
        worst[n] = (max(worst[n][0], float(d.max())), max(worst[n][1], float(scaled.max())))

    for feeds in feeds_list:
        got = session.run(None, {n: feeds[n] for n in graph_inputs})
        with torch.no_grad():
            want = module(*[torch.from_numpy(feeds[n]) for n in module_inputs(module, feeds)])
        if isinstance(want, torch.Tensor):
            want = (want,)
        want = [w.numpy() for w in want]
        for n, g, w in zip(out_names, got, want):
            update(n, g, w)
        logits = dict(zip(out_names, zip(got, want)))["logits"]
        update("probs", *(softmax(x) for x in logits))
    return worst


def softmax(x: np.ndarray) -> np.ndarray:
    """Softmax over the last axis, in float64."""
    e = np.exp(x.astype(np.float64) - x.max(axis=-1, keepdims=True))
    return e / e.sum(axis=-1, keepdims=True)


def module_inputs(module: torch.nn.Module, feeds: dict) -> list[str]:
    """The contract input names ``module.forward`` takes, in order (its parameter names)."""
    import inspect

    params = list(inspect.signature(module.forward).parameters)
    unknown = [p for p in params if p not in INPUTS]
    if unknown:
        raise TypeError(f"forward parameters {unknown} are not contract inputs {INPUTS}")
    return params


def check_graph(model: onnx.ModelProto) -> list[str]:
    """What the graph lacks of the contract or gets wrong in its names (empty when none):
    ``image``, ``logits`` and ``value`` are required; ``memory`` and ``memory_out`` come
    together or not at all; an input the contract does not name is refused, as groundscope
    refuses it; a graph without ``mission`` has no per-word outputs."""
    init = {t.name for t in model.graph.initializer}
    inputs = {i.name for i in model.graph.input if i.name not in init}
    outputs = {o.name for o in model.graph.output}
    problems = [f"no input {n!r}" for n in REQUIRED_INPUTS if n not in inputs]
    problems += [f"no output {n!r}" for n in REQUIRED_OUTPUTS if n not in outputs]
    problems += [f"input {n!r} is not in the contract" for n in sorted(inputs - set(INPUTS))]
    if "memory" in inputs and MEMORY_OUTPUT not in outputs:
        problems.append("input 'memory' but no output 'memory_out' (memory is both or neither)")
    if MEMORY_OUTPUT in outputs and "memory" not in inputs:
        problems.append("output 'memory_out' but no input 'memory' (memory is both or neither)")
    if "mission" not in inputs and outputs & {"word_maps", "word_weights"}:
        problems.append("per-word outputs but no input 'mission'")
    return problems


def reads(model: onnx.ModelProto) -> tuple[bool, bool]:
    """Whether the graph takes ``mission`` and ``memory``."""
    init = {t.name for t in model.graph.initializer}
    inputs = {i.name for i in model.graph.input if i.name not in init}
    return "mission" in inputs, "memory" in inputs


def describe(path: str | Path) -> str:
    """One line per input and output (name, element type, shape) and the op types."""
    model = onnx.load(str(path))
    lines = []
    for kind, values in (("input", model.graph.input), ("output", model.graph.output)):
        for v in values:
            t = v.type.tensor_type
            dims = [d.dim_param or str(d.dim_value) for d in t.shape.dim]
            dtype = onnx.TensorProto.DataType.Name(t.elem_type).lower()
            lines.append(f"  {kind:6} {v.name:13} {dtype:7} ({', '.join(dims)})")
    ops = sorted({n.op_type for n in model.graph.node})
    lines.append(f"  ops    {' '.join(ops)}")
    return "\n".join(lines)


def print_diffs(worst: dict[str, tuple[float, float]], tolerance: float) -> bool:
    """Prints the max abs diff of every output; True when every difference scaled by
    ``max(1, |value|)`` is within ``tolerance``."""
    ok = True
    for n, (d, scaled) in worst.items():
        flag = "ok" if scaled <= tolerance else f"ABOVE {tolerance:g}"
        ok &= scaled <= tolerance
        print(f"  max |onnx - torch| {n:13} {d:.3g}  (scaled {scaled:.3g})  {flag}")
    return ok
