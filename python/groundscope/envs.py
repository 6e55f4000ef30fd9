"""gymnasium classes around the Rust environments (``groundscope._core``).

``GroundscopeEnv`` behaves as ``gymnasium.make(id)`` over minigrid 3.2.0 for the same id and
seeds; ``GroundscopeVecEnv`` as ``gymnasium.make_vec(id, n, vectorization_mode="sync")``
(autoreset mode NEXT_STEP), with the envs stepped in Rust on a thread pool.
"""

from __future__ import annotations

import os
import string
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from . import _core

# BabyAI missions are lowercase words, spaces and commas ("go to the red ball, then open a
# door"); the longest generated ones (BossLevel) stay far below this length.
_MISSION_CHARSET = string.ascii_lowercase + " ,"
_MISSION_MAX_LENGTH = 1024


def observation_space() -> spaces.Dict:
    """The observation space of one env: minigrid's, with ``mission`` as a text space."""
    return spaces.Dict(
        {
            "direction": spaces.Discrete(4),
            "image": spaces.Box(0, 255, (7, 7, 3), np.uint8),
            # min_length 0: MiniGrid's Playground has an empty mission.
            "mission": spaces.Text(_MISSION_MAX_LENGTH, min_length=0, charset=_MISSION_CHARSET),
        }
    )


class GroundscopeEnv(gym.Env):
    """One BabyAI or MiniGrid env, seed-exact with minigrid 3.2.0 (use ``groundscope.make``)."""

    metadata = {"render_modes": []}

    def __init__(self, level: str, render_mode: str | None = None):
        if render_mode is not None:
            raise ValueError(f"render_mode: groundscope envs do not render, got {render_mode!r}")
        self._core = _core.Env(level)
        self.level = self._core.level
        self.observation_space = observation_space()
        # minigrid's: 7 actions, 3 on Dynamic-Obstacles (left, right, forward).
        self.action_space = spaces.Discrete(self._core.num_actions)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        image, direction, mission = self._core.reset(seed)
        # gymnasium's own generator (``self.np_random``), seeded as minigrid's would be; the
        # level itself comes from the Rust port of that same stream.
        if seed is not None:
            super().reset(seed=seed)
        return {"image": image, "direction": np.int64(direction), "mission": mission}, {}

    def step(self, action):
        # As minigrid: an action is an integer (Python's, numpy's or a 0-d integer array);
        # 2.7 or '2' is refused, not rounded or parsed.
        if isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iub":
            action = action.item()
        if not isinstance(action, (int, np.integer)):
            raise ValueError(f"Unknown action: {action!r} (actions are the integers 0-6)")
        a = int(action)
        image, direction, mission, reward, terminated, truncated = self._core.step(a)
        obs = {"image": image, "direction": np.int64(direction), "mission": mission}
        return obs, reward, terminated, truncated, {}

    @property
    def max_steps(self) -> int | None:
        """The current episode's horizon (BabyAI's depends on the mission)."""
        return self._core.max_steps

    @property
    def step_count(self) -> int | None:
        """Steps taken in the current episode."""
        return self._core.step_count

    @property
    def agent_pos(self):
        """The agent's position ``(x, y)``."""
        return self._core.agent_pos


# Envs per thread before a second thread pays: a BabyAI step costs about a microsecond, a
# fork-join across threads tens of them, and on the 2-core machine measured a second thread
# never helped a 64–4096-env vector (docs/performance.md#python-vector-envs).
ENVS_PER_THREAD = 256


def default_threads(num_envs: int) -> int:
    """The default thread count of a vector of ``num_envs`` envs: one per ``ENVS_PER_THREAD``
    envs, at most one per core."""
    return max(1, min(os.cpu_count() or 1, num_envs // ENVS_PER_THREAD))


class GroundscopeVecEnv(VectorEnv):
    """``num_envs`` BabyAI envs stepped in Rust (use ``groundscope.make_vec``).

    Equal step by step to ``gymnasium.make_vec(id, num_envs, vectorization_mode="sync")``
    over minigrid: ``reset(seed=s)`` seeds env ``i`` with ``s + i``; an env that ended is reset
    on the next step (its own generator continued), which returns reward 0 and both flags
    false. ``num_threads``: None one per 256 envs up to one per core, 0 one per core, 1 the
    calling thread. ``copy=False`` returns the
    preallocated arrays themselves (overwritten by the next step) instead of copies.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        level: str,
        num_envs: int,
        num_threads: int | None = None,
        copy: bool = True,
        render_mode: str | None = None,
    ):
        if render_mode is not None:
            raise ValueError(f"render_mode: groundscope envs do not render, got {render_mode!r}")
        if num_threads is None:
            num_threads = default_threads(num_envs) if isinstance(num_envs, int) else 1
        for name, value, low in (("num_envs", num_envs, 1), ("num_threads", num_threads, 0)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"{name} must be an int >= {low}, got {value!r}")
        self._core = _core.VecEnv(level, int(num_envs), int(num_threads))
        self.level = self._core.level
        self.num_envs = int(num_envs)
        self.copy = copy
        self.single_observation_space = observation_space()
        self.single_action_space = spaces.Discrete(self._core.num_actions)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        n = self.num_envs
        self._image = np.zeros((n, 7, 7, 3), np.uint8)
        self._direction = np.zeros(n, np.int64)
        self._reward = np.zeros(n, np.float64)
        self._terminated = np.zeros(n, np.bool_)
        self._truncated = np.zeros(n, np.bool_)
        self._missions: list[str] = [""] * n
        self._reset_once = False

    @property
    def num_threads(self) -> int:
        """Threads the envs are stepped on."""
        return self._core.num_threads

    def _obs(self):
        if self.copy:
            return {
                "image": self._image.copy(),
                "direction": self._direction.copy(),
                "mission": tuple(self._missions),
            }
        return {"image": self._image, "direction": self._direction, "mission": tuple(self._missions)}

    def reset(self, *, seed: int | list | None = None, options: dict[str, Any] | None = None):
        n = self.num_envs
        if seed is None:
            seeds = [None] * n
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(n)]
        elif isinstance(seed, (list, tuple)):
            if len(seed) != n:
                raise ValueError(f"seed: a list of {len(seed)} seeds for num_envs={n}")
            seeds = list(seed)
        else:
            raise ValueError(f"seed must be an int, a list of ints or None, got {seed!r}")
        mask = None
        if options is not None and "reset_mask" in options:
            mask = options["reset_mask"]
            if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (n,):
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({n},)")
            if not mask.any():
                raise ValueError("options['reset_mask'] must hold at least one True")
        self._missions = self._core.reset(seeds, self._image, self._direction, mask)
        if mask is None:
            self._terminated[:] = False
            self._truncated[:] = False
        else:
            self._terminated[mask] = False
            self._truncated[mask] = False
        self._reset_once = True
        return self._obs(), {}

    def step(self, actions):
        if not self._reset_once:
            raise RuntimeError("step() before reset(): call reset() first")
        a = np.asarray(actions)
        if a.shape != (self.num_envs,):
            raise ValueError(f"actions must have shape ({self.num_envs},), got {a.shape}")
        # An int past 64 bits (numpy holds it as an object) or a uint64 past int64 is named as
        # any bad action, not wrapped round nor an OverflowError.
        if a.dtype == np.uint64 and a.size and int(a.max()) >= 2**63:
            i = int(a.argmax())
            raise ValueError(f"actions[{i}] must be an action 0-6, got {int(a[i])}")
        if a.dtype == object:
            for i, v in enumerate(a.tolist()):
                if isinstance(v, int) and not isinstance(v, bool) and not -(2**63) <= v < 2**63:
                    raise ValueError(f"actions[{i}] must be an action 0-6, got {v}")
        if a.dtype.kind not in "iu":
            raise ValueError(f"actions must be integers 0-6, got dtype {a.dtype}")
        a = np.ascontiguousarray(a, dtype=np.int64)
        for i, mission in self._core.step(
            a, self._image, self._direction, self._reward, self._terminated, self._truncated
        ):
            self._missions[i] = mission
        if self.copy:
            return (
                self._obs(),
                self._reward.copy(),
                self._terminated.copy(),
                self._truncated.copy(),
                {},
            )
        return self._obs(), self._reward, self._terminated, self._truncated, {}
