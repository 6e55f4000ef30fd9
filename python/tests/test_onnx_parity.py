"""A graph run by onnxruntime inside a Python callable, evaluated with groundscope.evaluate,
against the same graph evaluated by `groundscope eval` (tract): episode by episode the same
actions, outcomes and — for a graph with word maps — the same grounding accuracies.

Needs onnxruntime and the groundscope binary (GROUNDSCOPE_BIN, else
$CARGO_TARGET_DIR/release/groundscope, else target/release/groundscope); skipped without.
"""

import csv
import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import groundscope
from conftest import find_groundscope_bin

ort = pytest.importorskip("onnxruntime")

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "tests" / "fixtures" / "onnx"


def groundscope_bin():
    exe = find_groundscope_bin()
    if exe is None:
        pytest.skip("no groundscope binary (set GROUNDSCOPE_BIN)")
    return exe


class OnnxAct:
    """An ONNX graph of docs/onnx.md's contract as a groundscope.evaluate callable: the
    memory kept by row and zeroed where ``first``; rows grouped by mission length, since the
    graph reads a batch of equal-length missions."""

    def __init__(self, path):
        self.sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        meta = self.sess.get_modelmeta().custom_metadata_map
        self.ids = {w: i for i, w in enumerate(json.loads(meta["groundscope.vocabulary"]))}
        self.memory_size = int(meta["groundscope.memory_size"])
        self.map_layout = meta.get("groundscope.map_layout", "image")
        self.inputs = {i.name: i.type for i in self.sess.get_inputs()}
        self.outputs = [o.name for o in self.sess.get_outputs()]
        self.memory = None

    def __call__(self, obs, first):
        n = len(obs["mission"])
        if self.memory is None or len(self.memory) != n:
            self.memory = np.zeros((n, self.memory_size), np.float32)
        self.memory[first] = 0.0
        words = [re.findall("([a-z]+)", m.lower()) for m in obs["mission"]]
        longest = max(len(w) for w in words)
        out = {"logits": np.zeros((n, 7), np.float32)}
        maps = "word_maps" in self.outputs
        if maps:
            out["word_maps"] = np.zeros((n, longest, 7, 7), np.float32)
            out["word_weights"] = np.zeros((n, longest), np.float32)
            out["combined_map"] = np.zeros((n, 7, 7), np.float32)
        for length in sorted({len(w) for w in words}):
            rows = [i for i in range(n) if len(words[i]) == length]
            dtype = np.int64 if self.inputs["image"] == "tensor(int64)" else np.float32
            feed = {
                "image": obs["image"][rows].astype(dtype),
                "mission": np.array([[self.ids[w] for w in words[i]] for i in rows], np.int64),
                "memory": self.memory[rows],
            }
            if "combined_override" in self.inputs:
                feed["combined_override"] = np.zeros((len(rows), 7, 7), np.float32)
                feed["override_weight"] = np.zeros(len(rows), np.float32)
            res = dict(zip(self.outputs, self.sess.run(self.outputs, feed)))
            out["logits"][rows] = res["logits"]
            self.memory[rows] = res["memory_out"]
            if maps:
                out["word_maps"][rows, :length] = res["word_maps"].reshape(len(rows), length, 7, 7)
                out["word_weights"][rows, :length] = res["word_weights"]
                out["combined_map"][rows] = res["combined_map"].reshape(len(rows), 7, 7)
        return out


def rows_of(out):
    with open(out / "episodes.csv", newline="") as f:
        return [{k: v for k, v in r.items() if k != "checkpoint"} for r in csv.DictReader(f)]


@pytest.mark.parametrize(
    "graph, level, cli_level",
    [
        ("acmodel_gotoredballgrey.onnx", "BabyAI-GoToRedBallGrey-v0", ["--levels", "BabyAI-GoToRedBallGrey-v0"]),
        ("bundled_attention.onnx", "groundscope-PaperLocalS8N4-v0", ["--sizes", "8", "--objects", "4"]),
    ],
)
def test_a_callable_and_the_cli_run_the_same_episodes(tmp_path, graph, level, cli_level):
    exe = groundscope_bin()
    path = FIXTURES / graph
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    subprocess.run(
        [exe, "eval", "--checkpoint", str(path), *cli_level, "--seeds", "2", "--episodes", "15",
         "--jobs", "1", "--quiet", "--out", str(cli_out)],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    act = OnnxAct(path)
    report = groundscope.evaluate(act, [level], seeds=2, episodes=15, out=py_out, map_layout=act.map_layout)
    cli_rows, py_rows = rows_of(cli_out), rows_of(py_out)
    assert len(py_rows) == 30
    for a, b in zip(cli_rows, py_rows):
        assert a == b, (a["level_seed"], a, b)
    cli_report = json.loads((cli_out / "report.json").read_text())
    cli_cell, py_cell = cli_report["cells"][0], report["cells"][0]
    assert py_cell["success"] == cli_cell["success"]
    assert report["checkpoints"][0]["variant"] == cli_report["checkpoints"][0]["variant"]
    if cli_cell.get("accuracy"):
        for kind in ("object", "color", "combined"):
            a, b = cli_cell["accuracy"][kind], py_cell["accuracy"][kind]
            assert a["evaluated_steps"] == b["evaluated_steps"] > 0
            for m in ("acc", "acc_ng", "acc_bs", "acc_cmb"):
                assert b[m]["mean"] == pytest.approx(a[m]["mean"], abs=1e-3), (kind, m)
