"""Shared helpers: the reference envs (gymnasium + minigrid 3.2.0) and comparisons."""

import gymnasium as gym
import minigrid
import numpy as np
import pytest

gym.register_envs(minigrid)

import groundscope  # noqa: E402

# Every registered BabyAI id, as minigrid registers them (and as groundscope ports them).
BABYAI_IDS = sorted(k for k in gym.registry if k.startswith("BabyAI-"))


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
