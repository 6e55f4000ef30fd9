"""A study planned by the CLI and run on a real local Ray cluster through
``groundscope.study.run_ray``: every run is a Ray task that trains, evaluates and leaves its
files in the study directory, where ``groundscope study collect`` reads them."""

import json
import subprocess

import pytest

import groundscope.study
from conftest import find_groundscope_bin

ray = pytest.importorskip("ray")


SPEC = """
seeds = [1, 2]
frames = 128
eval = ["--seeds", "1", "--episodes", "4"]

[recipes]
tiny = ["--procs", "4", "--frames-per-proc", "16", "--batch-size", "32", "--hidden", "16",
        "--eval-interval", "0", "--size", "5", "--objects", "1", "--tasks", "goto", "--no-done"]

[levels]
paper = { train = [], eval = ["--sizes", "5", "--objects", "1"] }
"""


def groundscope_bin():
    exe = find_groundscope_bin()
    if exe is None:
        pytest.fail("no groundscope binary: build it (cargo build --release) or set GROUNDSCOPE_BIN")
    return exe


def test_a_study_runs_as_ray_tasks_and_collects(tmp_path):
    gs = groundscope_bin()
    spec = tmp_path / "study.toml"
    spec.write_text(SPEC)
    study = tmp_path / "study"
    subprocess.run([gs, "study", "plan", str(spec), "--out", str(study)], check=True)
    m = groundscope.study.manifest(study)
    assert [r["name"] for r in m["runs"]] == ["tiny-paper-s1", "tiny-paper-s2"]
    ray.init(num_cpus=2, include_dashboard=False)
    try:
        codes = groundscope.study.run_ray(study, binary=gs)
        # A second pass skips the finished runs.
        again = groundscope.study.run_ray(study, binary=gs)
    finally:
        ray.shutdown()
    assert codes == {"tiny-paper-s1": 0, "tiny-paper-s2": 0}, codes
    assert again == codes
    for name in codes:
        run = study / "runs" / name
        assert (run / "study-done.json").is_file()
        assert (run / "eval" / "report.json").is_file()
        log = (run / "study.log").read_text()
        assert log.count("== groundscope train") == 1, log
    out = subprocess.run(
        [gs, "study", "collect", str(study)], check=True, capture_output=True, text=True
    ).stdout
    assert "collected 2 finished runs of 2" in out, out
    collected = json.loads((study / "report" / "collected.json").read_text())
    (row,) = collected["rows"]
    assert row["recipe"] == "tiny" and row["seeds"] == [1, 2]
    assert row["figures"]["success"]["mean"] is not None


def test_run_ray_refuses_what_is_not_a_study(tmp_path):
    with pytest.raises(ValueError, match="manifest.json"):
        groundscope.study.run_ray(tmp_path)
