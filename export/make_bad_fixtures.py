#!/usr/bin/env python3
"""Write the small ONNX graphs that groundscope's bad-input tests load (and one good one).

    python export/make_bad_fixtures.py tests/fixtures/onnx

Every file is a few kilobytes, built with the ``onnx`` helper API (no PyTorch): a tiny
policy of contract 1 (docs/onnx.md) — the mean of the view's codes, the mean of the
mission's word embeddings and the memory, concatenated, then three matrix products for the
logits, the value and the new memory — and one defect per file:

==========================  ===================================================================
``minimal.onnx``            none: the control, a valid graph every command accepts
``bad_missing_input.onnx``  no ``memory`` input, but a ``memory_out`` output (computed from the
                            view and the mission): memory is both or neither
``bad_missing_output.onnx`` no ``logits`` output (it is called ``action_logits``)
``bad_shape.onnx``          ``logits`` of 5 actions, (B, 5)
``bad_dtype.onnx``          ``memory`` declared int64 (cast to float inside)
``bad_operator.onnx``       a ``Loop`` (one iteration, adds 0 to the memory): valid ONNX that
                            onnxruntime runs but tract cannot
``bad_vocabulary.onnx``     the vocabulary has no ``"key"``
``bad_nan.onnx``            ``logits`` NaN on every input: ``+ (s − s) / (s − s)`` with ``s``
                            the sum of the memory, computed at run time (no initializer holds
                            the NaN, nothing to fold)
``bad_expand_bomb.onnx``    an allocation bomb: the view's mean ``Expand``\ ed to
                            (B, 8, 1 000 000 000) (32 GB a row; the shape made from the
                            input's batch size at run time), its sine summed and added × 1e-30
``bad_batch_bomb.onnx``     the same at (B, 1, 1 000 000): 4 MB a row, runs at small batches,
                            over 1 GiB from B = 269 on (an evaluation of 300 episodes)
``bad_constant_bomb.onnx``  an allocation bomb: ``ConstantOfShape [200000, 200000]`` (160 GB),
                            summed and added × 1e-30
``bad_negative_maps.onnx``  ``word_maps`` (B, L, 7, 7) whose every value is negative: a
                            softmax over the view, negated
``bad_opset.onnx``          opset 21 (newer than the runtime supports), logits by ``Gemm``
``bad_fixed_batch.onnx``    the batch size fixed inside the graph: the memory reshaped to the
                            constant shape (3, 8), as a trace with batch 3 would leave it
``bad_input_name.onnx``     the view input is called ``obs``, not ``image``
``fixed_dims.onnx``         runs, but its inputs declare batch 1 and a mission of 5 words
                            (``image`` (1, 7, 7, 3), ``mission`` (1, 5), ``memory`` (1, 8))
``renamed.onnx``            runs: its vocabulary is groundscope's mission words in another
                            order (other ids), its metadata name ``tiny policy (test)``;
                            no maps
==========================  ===================================================================

The two bombs are checked with ``onnx.checker`` only: running them is what they are for.

Each has the full metadata (but for the vocabulary of ``bad_vocabulary.onnx``); each is
checked with ``onnx.checker`` and, where the contract's feeds fit it, run with onnxruntime
to confirm it does what its name says.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

sys.path.insert(0, str(Path(__file__).resolve().parent))

import onnx_contract as oc  # noqa: E402

MEMORY = 8
EMB = 4
VOCABULARY = oc.GROUNDSCOPE_VOCABULARY


def tiny(
    *,
    mission: bool = True,
    memory_in: bool = True,
    logits_name: str = "logits",
    actions: int = 7,
    memory_int: bool = False,
    loop: bool = False,
    nan: bool = False,
    vocabulary: list[str] = VOCABULARY,
    name: str = "minimal",
    label: str | None = None,
    expand_bomb: tuple[int, int] | None = None,
    constant_bomb: bool = False,
    negative_maps: bool = False,
    opset: int = oc.OPSET,
    fixed_batch: int | None = None,
    image_name: str = "image",
    fixed_dims: bool = False,
) -> onnx.ModelProto:
    """The tiny policy with the chosen defect (``label``: the metadata name, else ``name``)."""
    rng = np.random.default_rng(0)
    feat = 1 + (EMB if mission else 0) + (MEMORY if memory_in else 0)

    def init(n: str, shape: tuple[int, ...]) -> onnx.TensorProto:
        return numpy_helper.from_array((0.3 * rng.standard_normal(shape)).astype(np.float32), n)

    inits = [init("emb", (len(vocabulary), EMB))] if mission else []
    inits += [
        init("w_logits", (feat, actions)),
        init("b_logits", (actions,)),
        init("w_value", (feat, 1)),
        init("w_memory", (feat, MEMORY)),
        numpy_helper.from_array(np.array([1], dtype=np.int64), "axis1"),
    ]
    def reduce_mean(x: str, out: str, axes: list[int], keepdims: int) -> onnx.NodeProto:
        # `axes` became an input in opset 18.
        if opset < 18:
            return helper.make_node("ReduceMean", [x], [out], axes=axes, keepdims=keepdims)
        inits.append(numpy_helper.from_array(np.array(axes, dtype=np.int64), f"{out}_axes"))
        return helper.make_node("ReduceMean", [x, f"{out}_axes"], [out], keepdims=keepdims)

    batch, words = (1, 5) if fixed_dims else ("batch", "words")
    inputs = [helper.make_tensor_value_info(image_name, TensorProto.FLOAT, [batch, 7, 7, 3])]
    if mission:
        inputs.append(
            helper.make_tensor_value_info("mission", TensorProto.INT64, [batch, words]))
    mem_type = TensorProto.INT64 if memory_int else TensorProto.FLOAT
    if memory_in:
        inputs.append(helper.make_tensor_value_info("memory", mem_type, [batch, MEMORY]))

    nodes = [
        # View: mean of all codes, (B, 1).
        reduce_mean(image_name, "view", [1, 2, 3], 0),
        helper.make_node("Unsqueeze", ["view", "axis1"],
                         ["view_raw" if expand_bomb or constant_bomb else "view1"]),
    ]
    if expand_bomb or constant_bomb:
        # The bomb's sum × 1e-30 is added to the view: on the outputs' path, not foldable.
        inits.append(numpy_helper.from_array(np.array(1e-30, dtype=np.float32), "zero_bomb"))
        if expand_bomb:
            # The target shape (B, 8, 1e9) is built from the input's own batch size, as
            # PyTorch exports `x.expand(B, 8, 10**9)`: it is no constant that could be read
            # from the file; only the shapes groundscope's runtime infers show it.
            inits += [
                numpy_helper.from_array(np.array([2], dtype=np.int64), "axis2"),
                numpy_helper.from_array(np.array([0], dtype=np.int64), "start0"),
                numpy_helper.from_array(np.array(expand_bomb, dtype=np.int64), "bomb_tail"),
            ]
            nodes += [
                helper.make_node("Unsqueeze", ["view_raw", "axis2"], ["view3"]),
                helper.make_node("Shape", ["view3"], ["view3_shape"]),
                helper.make_node("Slice", ["view3_shape", "start0", "axis1"], ["bomb_batch"]),
                helper.make_node("Concat", ["bomb_batch", "bomb_tail"], ["bomb_shape"], axis=0),
                helper.make_node("Expand", ["view3", "bomb_shape"], ["bomb"], name=f"{name[4:]}"),
                # An element-wise op between: nothing a runtime could fold into the reduction.
                helper.make_node("Sin", ["bomb"], ["bomb_sin"]),
                helper.make_node("ReduceSum", ["bomb_sin", "axis1"], ["bomb_sum3"], keepdims=0),
                reduce_mean("bomb_sum3", "bomb_sum", [1], 1),
            ]
        else:
            inits.append(numpy_helper.from_array(np.array([200_000, 200_000], dtype=np.int64),
                                                 "bomb_shape"))
            nodes += [
                helper.make_node("ConstantOfShape", ["bomb_shape"], ["bomb"], name="constant_bomb",
                                 value=numpy_helper.from_array(np.array([1.0], dtype=np.float32))),
                helper.make_node("ReduceSum", ["bomb"], ["bomb_sum"], keepdims=0),
            ]
        nodes += [
            helper.make_node("Mul", ["bomb_sum", "zero_bomb"], ["bomb_zero"]),
            helper.make_node("Add", ["view_raw", "bomb_zero"], ["view1"]),
        ]
    if memory_int:
        nodes.append(helper.make_node("Cast", ["memory"], ["memory_f"], to=TensorProto.FLOAT))
        mem = "memory_f"
    elif fixed_batch is not None:
        # What a trace at batch size N leaves behind: a reshape to the constant (N, M).
        inits.append(numpy_helper.from_array(np.array([fixed_batch, MEMORY], dtype=np.int64),
                                             "fixed_shape"))
        nodes.append(helper.make_node("Reshape", ["memory", "fixed_shape"], ["memory_r"],
                                      name="reshape_fixed_batch"))
        mem = "memory_r"
    else:
        mem = "memory"
    parts = ["view1"]
    if mission:
        nodes += [
            helper.make_node("Gather", ["emb", "mission"], ["words_e"], axis=0),
            reduce_mean("words_e", "text", [1], 0),
        ]
        parts.append("text")
    if memory_in:
        parts.append(mem)
    nodes.append(helper.make_node("Concat", parts, ["z"], axis=1))
    if opset >= 19:
        nodes.append(helper.make_node("Gemm", ["z", "w_logits", "b_logits"], [logits_name]))
    else:
        nodes += [
            helper.make_node("MatMul", ["z", "w_logits"], ["logits_mm"]),
            helper.make_node("Add", ["logits_mm", "b_logits"],
                             ["logits_raw" if nan else logits_name]),
        ]
    nodes += [
        helper.make_node("MatMul", ["z", "w_value"], ["value_2d"]),
        helper.make_node("Squeeze", ["value_2d", "axis1"], ["value"]),
        helper.make_node("MatMul", ["z", "w_memory"], ["memory_mm"]),
        helper.make_node("Tanh", ["memory_mm"], ["memory_loop" if loop else "memory_out"]),
    ]
    if nan:
        # s − s is 0 for any finite memory, 0 / 0 is NaN: made from the input at run time.
        nodes += [
            helper.make_node("ReduceSum", [mem], ["s"], keepdims=1),
            helper.make_node("Sub", ["s", "s"], ["zero"]),
            helper.make_node("Div", ["zero", "zero"], ["nan"]),
            helper.make_node("Add", ["logits_raw", "nan"], [logits_name]),
        ]
    if loop:
        # One iteration that adds 0 to the memory: body(iter, cond, v) → (cond, v + 0).
        body = helper.make_graph(
            [
                helper.make_node("Identity", ["cond_in"], ["cond_out"]),
                helper.make_node("Add", ["v_in", "zero_f"], ["v_out"]),
            ],
            "loop_body",
            [
                helper.make_tensor_value_info("iter", TensorProto.INT64, []),
                helper.make_tensor_value_info("cond_in", TensorProto.BOOL, []),
                helper.make_tensor_value_info("v_in", TensorProto.FLOAT, None),
            ],
            [
                helper.make_tensor_value_info("cond_out", TensorProto.BOOL, []),
                helper.make_tensor_value_info("v_out", TensorProto.FLOAT, None),
            ],
            [numpy_helper.from_array(np.array(0.0, dtype=np.float32), "zero_f")],
        )
        inits += [
            numpy_helper.from_array(np.array(1, dtype=np.int64), "trip"),
            numpy_helper.from_array(np.array(True), "cond"),
        ]
        nodes.append(helper.make_node("Loop", ["trip", "cond", "memory_loop"], ["memory_out"],
                                      body=body))
    outputs = [
        helper.make_tensor_value_info(logits_name, TensorProto.FLOAT, [batch, actions]),
        helper.make_tensor_value_info("value", TensorProto.FLOAT, [batch]),
        helper.make_tensor_value_info("memory_out", TensorProto.FLOAT, [batch, MEMORY]),
    ]
    if negative_maps:
        # word_maps = −softmax over the 49 cells of each word's embedding × a matrix.
        inits += [
            init("w_maps", (EMB, 49)),
            numpy_helper.from_array(np.array([0, 0, 7, 7], dtype=np.int64), "maps_shape"),
        ]
        nodes += [
            helper.make_node("MatMul", ["words_e", "w_maps"], ["maps_logits"]),
            helper.make_node("Softmax", ["maps_logits"], ["maps_pos"], axis=-1),
            helper.make_node("Neg", ["maps_pos"], ["maps_flat"]),
            helper.make_node("Reshape", ["maps_flat", "maps_shape"], ["word_maps"]),
        ]
        outputs.append(helper.make_tensor_value_info("word_maps", TensorProto.FLOAT,
                                                     ["batch", "words", 7, 7]))
    graph = helper.make_graph(nodes, name, inputs, outputs, inits)
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", opset)],
        producer_name="groundscope make_bad_fixtures.py",
    )
    model.ir_version = 8
    model.doc_string = f"groundscope test fixture {name}.onnx (tests/fixtures/onnx/README.md)"
    oc.set_metadata(model, oc.metadata(vocabulary, MEMORY, oc.DEFAULT_LEVEL, "image", label or name))
    onnx.checker.check_model(model, full_check=True)
    return model


FIXTURES = {
    "minimal": {},
    "bad_missing_input": {"memory_in": False},
    "bad_missing_output": {"logits_name": "action_logits"},
    "bad_shape": {"actions": 5},
    "bad_dtype": {"memory_int": True},
    "bad_operator": {"loop": True},
    "bad_vocabulary": {"vocabulary": [w for w in VOCABULARY if w != "key"]},
    "bad_nan": {"nan": True},
    "bad_expand_bomb": {"expand_bomb": (8, 1_000_000_000)},
    "bad_batch_bomb": {"expand_bomb": (1, 1_000_000)},
    "bad_constant_bomb": {"constant_bomb": True},
    "bad_negative_maps": {"negative_maps": True},
    "bad_opset": {"opset": 21},
    "bad_fixed_batch": {"fixed_batch": 3},
    "bad_input_name": {"image_name": "obs"},
    "fixed_dims": {"fixed_dims": True},
    "renamed": {
        "vocabulary": ["<pad>"] + [w for w in reversed(oc.MISSION_WORDS)],
        "label": "tiny policy (test)",
    },
}

#: Not run with onnxruntime: they would take its memory (the bombs), or the feeds do not fit.
NOT_RUN = {"bad_expand_bomb", "bad_constant_bomb", "bad_input_name", "fixed_dims"}


def run(path: Path, vocabulary: list[str]) -> dict[str, np.ndarray]:
    """Runs a fixture with onnxruntime on contract feeds (those it declares, cast to its
    declared types), missions drawn from its ``vocabulary``."""
    import onnxruntime as ort

    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(1)
    feeds = oc.random_feeds(rng, 3, 4, vocabulary, MEMORY, np.float32)
    given = {}
    for i in session.get_inputs():
        x = feeds["image" if i.name == "obs" else i.name]
        given[i.name] = x.astype(np.int64) if i.type == "tensor(int64)" else x
    return dict(zip([o.name for o in session.get_outputs()], session.run(None, given)))


def main() -> int:
    out_dir = Path(sys.argv[1] if len(sys.argv) > 1 else "tests/fixtures/onnx")
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, defect in FIXTURES.items():
        path = out_dir / f"{name}.onnx"
        onnx.save(tiny(name=name, **defect), str(path))
        if name in NOT_RUN:
            print(f"wrote {path} ({path.stat().st_size} bytes): checked, not run")
            continue
        out = run(path, defect.get("vocabulary", VOCABULARY))
        logits = out.get("logits", out.get("action_logits"))
        shape = {k: v.shape for k, v in out.items()}
        print(f"wrote {path} ({path.stat().st_size} bytes): onnxruntime gives {shape}")
        assert logits is not None
        if name == "bad_nan":
            assert np.isnan(logits).all(), "bad_nan must give NaN logits"
        else:
            assert np.isfinite(logits).all()
        if name == "bad_shape":
            assert logits.shape[1] == 5
        if name == "bad_negative_maps":
            assert (out["word_maps"] < 0).all(), "bad_negative_maps must give negative maps"
    return 0


if __name__ == "__main__":
    sys.exit(main())
