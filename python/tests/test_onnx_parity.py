"""A graph run by onnxruntime inside a Python callable, evaluated with groundscope.evaluate,
against the same graph evaluated by `groundscope eval` (tract): episode by episode the same
actions, outcomes and — for a graph with word maps — the same grounding accuracies. And
rl-starter-files' ACModels on MiniGrid's own environments (image only, with memory, with
memory and text): the callable's episodes equal the graph's own Python evaluation in minigrid
(export/eval_in_python.py, committed beside each graph as NAME_python.csv).

Needs onnxruntime; the comparisons with the CLI also the groundscope binary (GROUNDSCOPE_BIN,
else $CARGO_TARGET_DIR/release/groundscope, else target/release/groundscope), skipped without.
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
    graph reads a batch of equal-length missions. A graph without a ``mission`` input is fed
    no mission (all rows at once), one without memory no memory."""

    def __init__(self, path):
        self.sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        meta = self.sess.get_modelmeta().custom_metadata_map
        self.inputs = {i.name: i.type for i in self.sess.get_inputs()}
        self.outputs = [o.name for o in self.sess.get_outputs()]
        self.reads_mission = "mission" in self.inputs
        self.has_memory = "memory" in self.inputs
        vocabulary = json.loads(meta["groundscope.vocabulary"]) if self.reads_mission else []
        self.ids = {w: i for i, w in enumerate(vocabulary)}
        self.memory_size = int(meta.get("groundscope.memory_size", "0")) if self.has_memory else 0
        self.map_layout = meta.get("groundscope.map_layout", "image")
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
        group = [len(w) if self.reads_mission else 0 for w in words]
        for length in sorted(set(group)):
            rows = [i for i in range(n) if group[i] == length]
            dtype = np.int64 if self.inputs["image"] == "tensor(int64)" else np.float32
            feed = {"image": obs["image"][rows].astype(dtype)}
            if self.reads_mission:
                feed["mission"] = np.array([[self.ids[w] for w in words[i]] for i in rows],
                                           np.int64)
            if self.has_memory:
                feed["memory"] = self.memory[rows]
            if "combined_override" in self.inputs:
                feed["combined_override"] = np.zeros((len(rows), 7, 7), np.float32)
                feed["override_weight"] = np.zeros(len(rows), np.float32)
            res = dict(zip(self.outputs, self.sess.run(self.outputs, feed)))
            out["logits"][rows] = res["logits"]
            if self.has_memory:
                self.memory[rows] = res["memory_out"]
            if maps:
                out["word_maps"][rows, :length] = res["word_maps"].reshape(len(rows), length, 7, 7)
                out["word_weights"][rows, :length] = res["word_weights"]
                out["combined_map"][rows] = res["combined_map"].reshape(len(rows), 7, 7)
        return out


def rows_of(out):
    return csv_rows(out / "episodes.csv")


def csv_rows(path):
    with open(path, newline="") as f:
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


# rl-starter-files' ACModel trained briefly in PyTorch on MiniGrid's own environments
# (export/make_fixtures.sh): image only, with memory, with memory and text.
MINIGRID_AGENTS = ["acmodel_doorkey.onnx", "acmodel_doorkey_mem.onnx", "acmodel_fetch.onnx"]
# The columns of an episode both evaluations write (``failure_class`` is groundscope's own
# analysis; the Python evaluation leaves it empty).
EPISODE_COLUMNS = ["level", "eval_seed", "episode", "level_seed", "mission", "success", "steps",
                   "actions"]


@pytest.mark.parametrize("graph", MINIGRID_AGENTS)
def test_a_callable_running_a_minigrid_agent_gives_its_own_python_evaluation(tmp_path, graph):
    path = FIXTURES / graph
    python = csv_rows(FIXTURES / graph.replace(".onnx", "_python.csv"))
    # The sweep the fixture holds: its levels in order, its seeds and episodes per seed.
    levels = list(dict.fromkeys(r["level"] for r in python))
    seeds = len({r["eval_seed"] for r in python})
    episodes = 1 + max(int(r["episode"]) for r in python)
    assert len(python) == len(levels) * seeds * episodes
    act = OnnxAct(path)
    assert (act.reads_mission, act.has_memory) == {
        "acmodel_doorkey.onnx": (False, False),
        "acmodel_doorkey_mem.onnx": (False, True),
        "acmodel_fetch.onnx": (True, True),
    }[graph]
    report = groundscope.evaluate(act, levels, seeds=seeds, episodes=episodes,
                                  out=tmp_path / "py", name=graph)
    ours = rows_of(tmp_path / "py")
    assert len(ours) == len(python)
    for a, b in zip(ours, python):
        for col in EPISODE_COLUMNS:
            assert a[col] == b[col], (col, a, b)
        assert float(a["return"]) == pytest.approx(float(b["return"]), abs=1e-6)
    assert [c["level"] for c in report["cells"]] == levels
