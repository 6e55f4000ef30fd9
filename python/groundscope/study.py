"""Studies on a Ray cluster: a study planned by ``groundscope study plan`` run as Ray tasks.

    import groundscope.study
    groundscope.study.run_ray("studies/paper", address="auto")   # or address=None: local

Each run of the study's ``manifest.json`` is one Ray task with ``num_cpus`` equal to its
training threads; the task runs the run's line of ``commands.txt`` (``groundscope study exec
STUDY NAME``: train, resumed where it was killed, then eval and faithfulness), so the results
land in the study directory as a local ``groundscope study run`` leaves them, and
``groundscope study collect STUDY`` reads them. A finished run is skipped; a run whose lock is
held (running elsewhere) is left alone. Needs ``pip install groundscope[ray]`` and the
``groundscope`` binary (``manifest.json`` names the one that planned the study; ``binary=``
overrides it). The study directory must be reachable at the same path from every node.
"""

from __future__ import annotations

import json
import os
import subprocess

__all__ = ["run_ray", "manifest"]


def manifest(study: str | os.PathLike) -> dict:
    """The study's ``manifest.json``."""
    path = os.path.join(os.fspath(study), "manifest.json")
    try:
        with open(path) as f:
            m = json.load(f)
    except OSError as e:
        raise ValueError(f"{path}: {e.strerror} (plan the study first: groundscope study plan)") from None
    if m.get("format") != "groundscope-study":
        raise ValueError(f"{path}: not a groundscope study manifest")
    return m


def _exec(binary: str, study: str, name: str) -> tuple[str, int]:
    done = subprocess.run([binary, "study", "exec", study, name], capture_output=True, text=True)
    return name, done.returncode


def run_ray(
    study: str | os.PathLike,
    address: str | None = None,
    *,
    binary: str | None = None,
    runs: list[str] | None = None,
) -> dict[str, int]:
    """Runs the study's runs (all, or those named in ``runs``) as Ray tasks on the cluster at
    ``address`` (None: ``ray.init()``'s default, a local cluster unless one is running) and
    waits for them. Returns each run's exit status (0: done or running elsewhere; 1: a step
    failed, its output in ``STUDY/runs/NAME/study.log``; 130: interrupted)."""
    try:
        import ray
    except ImportError:
        raise ImportError("groundscope.study.run_ray needs Ray: pip install 'groundscope[ray]'") from None
    study = os.path.abspath(os.fspath(study))
    m = manifest(study)
    binary = binary or m["binary"]
    if not (os.path.isfile(binary) and os.access(binary, os.X_OK)):
        raise ValueError(f"binary {binary!r} is not an executable (pass binary=)")
    todo = [r for r in m["runs"] if runs is None or r["name"] in runs]
    unknown = set(runs or []) - {r["name"] for r in m["runs"]}
    if unknown:
        raise ValueError(f"the study has no run {sorted(unknown)[0]!r}")
    if not ray.is_initialized():
        ray.init(address=address, include_dashboard=False)
    task = ray.remote(_exec)
    refs = [task.options(num_cpus=r["threads"]).remote(binary, study, r["name"]) for r in todo]
    return dict(ray.get(refs))
