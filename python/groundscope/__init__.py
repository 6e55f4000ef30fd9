"""groundscope in Python: BabyAI environments seed-exact with minigrid 3.2.0 and stepped in
Rust, and evaluation and recording of any Python policy with groundscope's metrics.

    import groundscope
    env = groundscope.make("BabyAI-GoToLocal-v0")          # a gymnasium.Env
    envs = groundscope.make_vec("BabyAI-GoToLocal-v0", 64)  # a gymnasium VectorEnv
    groundscope.evaluate(act, levels=["BabyAI-GoToLocal-v0"], out="run")

The envs are also registered with gymnasium as ``groundscope/BabyAI-…-v0``.
"""

from __future__ import annotations

import gymnasium as gym

from . import _core
from .envs import GroundscopeEnv, GroundscopeVecEnv

__all__ = [
    "GroundscopeEnv",
    "GroundscopeVecEnv",
    "MINIGRID_VERSION",
    "level_ids",
    "make",
    "make_vec",
]

NAMESPACE = "groundscope"

#: The minigrid release the environments reproduce.
MINIGRID_VERSION: str = _core.MINIGRID_VERSION


def level_ids() -> list[str]:
    """Every registered BabyAI id of minigrid 3.2.0, in registration order."""
    return list(_core.level_ids())


def _bare(id: str) -> str:
    if not isinstance(id, str):
        raise ValueError(f"id must be a str, got {id!r}")
    prefix = NAMESPACE + "/"
    return id[len(prefix):] if id.startswith(prefix) else id


def _register(level: str) -> str:
    """Registers ``groundscope/<level>`` with gymnasium (once) and returns that id."""
    full = f"{NAMESPACE}/{level}"
    if full not in gym.registry:
        gym.register(
            id=full,
            entry_point="groundscope.envs:GroundscopeEnv",
            vector_entry_point="groundscope.envs:GroundscopeVecEnv",
            kwargs={"level": level},
        )
    return full


def make(id: str, **kwargs) -> gym.Env:
    """The env of level ``id`` as ``gymnasium.make(id)`` makes minigrid's: the same
    observations, rewards, terminations and truncations for the same seeds.

    ``id`` is a BabyAI id (``BabyAI-GoToLocal-v0``, with or without the ``groundscope/``
    namespace) or the paper's level ``groundscope-PaperLocalS{S}N{N}-v0``. An unknown id is a
    ``ValueError`` naming the closest ones.
    """
    level = _bare(id)
    # Checked here so that a bad id is one line naming it, not gymnasium's registry error.
    _core.Env(level)
    return gym.make(_register(level), **kwargs)


def make_vec(id: str, num_envs: int, *, num_threads: int = 0, copy: bool = True) -> GroundscopeVecEnv:
    """``num_envs`` envs of level ``id`` as one ``gymnasium.vector.VectorEnv``, equal step by
    step to ``gymnasium.make_vec(id, num_envs, vectorization_mode="sync")`` over minigrid
    (autoreset mode NEXT_STEP), stepped in Rust on ``num_threads`` threads (0: one per core)
    with the GIL released."""
    level = _bare(id)
    _register(level)
    return GroundscopeVecEnv(level, num_envs, num_threads=num_threads, copy=copy)


for _level in _core.level_ids():
    _register(_level)
del _level
