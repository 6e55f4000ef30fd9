"""Shared helpers: the reference envs (gymnasium + minigrid 3.2.0) and comparisons."""

import os
import shutil
from pathlib import Path

import gymnasium as gym
import minigrid
import numpy as np
import pytest

gym.register_envs(minigrid)

import groundscope  # noqa: E402

# Every registered BabyAI id, as minigrid registers them (and as groundscope ports them).
BABYAI_IDS = sorted(k for k in gym.registry if k.startswith("BabyAI-"))
# MiniGrid's own ids but the 6 WFC ones, which minigrid's wheel cannot build.
MINIGRID_IDS = sorted(
    k for k in gym.registry if k.startswith("MiniGrid-") and not k.startswith("MiniGrid-WFC-")
)


@pytest.fixture(scope="session", autouse=True)
def same_minigrid():
    """The port is of minigrid 3.2.0; another version may generate other levels."""
    assert minigrid.__version__ == groundscope.MINIGRID_VERSION, minigrid.__version__


def assert_obs_equal(ours, ref, where):
    """One env's observation dict, field by field."""
    assert set(ours) == set(ref), where
    assert ours["image"].dtype == np.uint8 and ours["image"].shape == (7, 7, 3), where
    np.testing.assert_array_equal(ours["image"], ref["image"], err_msg=where)
    assert int(ours["direction"]) == int(ref["direction"]), where
    assert ours["mission"] == ref["mission"], where


def assert_batch_equal(ours, ref, where):
    """A vector env's batched observation dict."""
    assert set(ours) == set(ref), where
    assert ours["image"].dtype == ref["image"].dtype, where
    np.testing.assert_array_equal(ours["image"], ref["image"], err_msg=where)
    assert ours["direction"].dtype == ref["direction"].dtype, where
    np.testing.assert_array_equal(ours["direction"], ref["direction"], err_msg=where)
    assert isinstance(ours["mission"], tuple), where
    assert ours["mission"] == ref["mission"], where


def find_groundscope_bin():
    """The groundscope binary the tests run: $GROUNDSCOPE_BIN, the release build in
    $CARGO_TARGET_DIR or target/, or one on PATH; None without."""
    root = Path(__file__).resolve().parents[2]
    candidates = [
        os.environ.get("GROUNDSCOPE_BIN"),
        os.environ.get("CARGO_TARGET_DIR")
        and os.path.join(os.environ["CARGO_TARGET_DIR"], "release", "groundscope"),
        str(root / "target" / "release" / "groundscope"),
        shutil.which("groundscope"),
    ]
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    return None
