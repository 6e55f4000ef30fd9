"""groundscope in Python: BabyAI environments seed-exact with minigrid 3.2.0 and stepped in
Rust, and evaluation and recording of any Python policy with groundscope's metrics.

    import groundscope
    env = groundscope.make("BabyAI-GoToLocal-v0")          # a gymnasium.Env
    envs = groundscope.make_vec("BabyAI-GoToLocal-v0", 64)  # a gymnasium VectorEnv
    groundscope.evaluate(act, levels=["BabyAI-GoToLocal-v0"], out="run")
    groundscope.train("runs/a", "BabyAI-GoToLocal-v0", frames=1_000_000, imitate=True)

The envs are also registered with gymnasium as ``groundscope/BabyAI-…-v0``.
"""

from __future__ import annotations

import json
import os

import gymnasium as gym

from . import _core
from .envs import GroundscopeEnv, GroundscopeVecEnv

__all__ = [
    "__version__",
    "GroundscopeEnv",
    "GroundscopeVecEnv",
    "MINIGRID_VERSION",
    "evaluate",
    "level_ids",
    "make",
    "make_vec",
    "record",
    "train",
]

NAMESPACE = "groundscope"

try:
    from importlib.metadata import PackageNotFoundError, version as _version

    #: The installed package's version (the Rust crate's, from pyproject.toml).
    __version__: str = _version("groundscope")
except PackageNotFoundError:  # imported from a source tree without installing
    __version__ = "0+unknown"

#: The minigrid release the environments reproduce.
MINIGRID_VERSION: str = _core.MINIGRID_VERSION


def level_ids() -> list[str]:
    """Every id of minigrid 3.2.0 groundscope builds: BabyAI's 96, then MiniGrid's 76."""
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

    ``id`` is a BabyAI or MiniGrid id (``BabyAI-GoToLocal-v0``, ``MiniGrid-DoorKey-5x5-v0``,
    with or without the ``groundscope/`` namespace), the paper's level
    ``groundscope-PaperLocalS{S}N{N}-v0``, or a MiniGrid class with its keyword arguments
    (``"MultiRoomEnv(minNumRooms=7, maxNumRooms=7)"``): then the env equals minigrid's class
    built with those arguments, unwrapped as that class is. An unknown id is a
    ``ValueError`` naming the closest ones.
    """
    level = _bare(id)
    # Checked here so that a bad id is one line naming it, not gymnasium's registry error.
    _core.Env(level)
    if _is_class(level):
        return GroundscopeEnv(level, **kwargs)
    return gym.make(_register(level), **kwargs)


def _is_class(level: str) -> bool:
    """A class spelt with its arguments (gymnasium's registry cannot hold such a name)."""
    return "(" in level


def make_vec(
    id: str, num_envs: int, *, num_threads: int | None = None, copy: bool = True
) -> GroundscopeVecEnv:
    """``num_envs`` envs of level ``id`` as one ``gymnasium.vector.VectorEnv``, equal step by
    step to ``gymnasium.make_vec(id, num_envs, vectorization_mode="sync")`` over minigrid
    (autoreset mode NEXT_STEP), stepped in Rust with the GIL released on ``num_threads``
    threads: None (default) one per 256 envs up to one per core, 0 one per core, 1 the
    calling thread. ``copy=False`` returns the preallocated arrays, overwritten by the next
    step."""
    level = _bare(id)
    if not _is_class(level):
        _register(level)
    return GroundscopeVecEnv(level, num_envs, num_threads=num_threads, copy=copy)


def _check_count(name: str, value) -> None:
    """A seed or count: a non-negative int below 2**64, else a ``ValueError`` naming it (the
    Rust side's conversion would raise an ``OverflowError`` naming nothing)."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**64:
        raise ValueError(f"{name} must be a non-negative int below 2**64, got {value!r}")


def evaluate(
    act,
    levels,
    seeds: int = 5,
    episodes: int = 100,
    out: str | os.PathLike = "run",
    first_seed: int = 0,
    sample: bool = False,
    *,
    alpha: float = 0.5,
    name: str = "python",
    map_layout: str = "image",
    top_k: int = 10,
) -> dict:
    """Evaluates a Python policy as ``groundscope eval`` evaluates a checkpoint, writing the
    same report to ``out`` (report.md, report.json, episodes.csv, the CSV tables, figures).

    ``act(obs, first)`` gets a batch dict (``image`` (N,7,7,3) uint8, ``direction`` (N,)
    int64, ``mission`` a list of N str) and a bool array ``first`` (N,) marking episode
    starts (a recurrent policy resets its memory there). Row ``i`` is the same episode at
    every call; a finished episode's row repeats its last observation and its output is
    ignored. It returns logits (N,7) — or (N,3) for a policy of MiniGrid's first three
    actions only (left, right, forward: Dynamic-Obstacles' action space), whose actions are
    then always among those three — or a dict with ``logits`` and optionally ``word_maps``
    (N,L,7,7) — one map per mission word (BabyAI's split: runs of a-z), in the axis order of
    ``image`` (``map_layout="image"``, ``[vx][vy]``) or ``"agent-up"`` (``[vy][vx]``) —
    ``word_weights`` (N,L), ``combined_map`` (N,7,7) and ``values`` (N,). The logits' width
    is read from the first call and must stay the same at every later one (else a
    ``ValueError``). With word maps the report holds the grounding accuracies.

    ``levels``: BabyAI ids (or ``groundscope-PaperLocalS{S}N{N}-v0``); episode ``e`` of
    evaluation seed ``s`` runs level seed ``s * 10**6 + e``. Greedy actions unless ``sample``.
    Returns report.json's content as a dict.
    """
    if isinstance(levels, str):
        levels = [levels]
    for k, v in (("seeds", seeds), ("episodes", episodes), ("first_seed", first_seed), ("top_k", top_k)):
        _check_count(k, v)
    report = _core.evaluate(
        act,
        [_bare(level) for level in levels],
        seeds,
        episodes,
        os.fspath(out),
        first_seed,
        bool(sample),
        float(alpha),
        str(name),
        map_layout,
        top_k,
    )
    return json.loads(report)


def record(
    act,
    level: str,
    seed: int,
    path: str | os.PathLike,
    sample: bool = False,
    *,
    alpha: float = 0.5,
    name: str = "python",
    map_layout: str = "image",
):
    """Runs ``act`` (as in :func:`evaluate`, with N = 1) on one episode of ``level`` from level
    seed ``seed`` and writes what ``groundscope replay`` writes: a Rerun recording (``.rrd``)
    or MCAP (``.mcap``), word maps included when ``act`` returns them, and the probabilities
    of the 3 or 7 actions its logits score. Returns ``(success, steps, reward)``."""
    _check_count("seed", seed)
    return _core.record(
        act, _bare(level), seed, os.fspath(path), bool(sample), float(alpha), str(name), map_layout
    )


def train(
    out: str | os.PathLike,
    levels: str | list[str] | None = None,
    frames: int | None = None,
    *,
    resume: bool = False,
    callback=None,
    **settings,
) -> dict:
    """Trains a run in ``out`` as ``groundscope train --out`` does — the same run directory
    (model, checkpoints, log.csv, eval_log.csv, curve), so that either resumes the other's.

    A new run trains on ``levels`` (a BabyAI id, a paper level's id or a list of them, in equal
    shares) to ``frames`` frames in all. The settings are ``groundscope train``'s flags in
    snake case (``--frames-per-proc``: ``frames_per_proc``), each a run's default when left out
    or ``None`` (the command's defaults, kept in one place by the core — ``frames`` included):
    ``model`` ("attention" or "baseline"), ``hidden``, ``seed``, ``init`` (a checkpoint, run
    directory or bundled name to start from); PPO's ``procs``, ``frames_per_proc``,
    ``epochs``, ``batch_size``, ``recurrence``, ``lr``, ``adam_eps``, ``discount``,
    ``gae_lambda``, ``entropy_coef``, ``value_loss_coef``, ``max_grad_norm``, ``clip_eps``,
    ``threads``, ``reward_scale``, ``normalize_advantages``; ``imitate`` (clone minigrid's bot
    instead of PPO), ``imitate_policy_share`` and ``teacher`` ("[ID=]CHECKPOINT", or a list of
    them: trained models whose greedy actions imitation learns, as ``train --teacher``); the
    maps' ``ground_loss``,
    ``word_temperature_anneal`` ("START:END") and ``freeze_attention_at``; and the tracking
    ones ``eval_interval``, ``eval_episodes``, ``save_interval``.

    ``resume=True`` goes on from the run's last checkpoint with its own settings: one given
    with another value than the run's is a ``ValueError`` naming it (the tracking ones may
    change; ``init`` starts a new run and is refused). ``callback(log)`` gets each update's
    log (a dict: update, frames, success_rate, mean_reward, entropy, losses, fps); returning
    ``False`` stops the run, saved. Ctrl-C stops it after the update, saved. Bad input is a
    ``ValueError`` raised before anything is written (imitation on levels the bot labels
    nothing of included). Returns the last update's log with ``checkpoint``, the run
    directory (what ``init``, ``groundscope eval --checkpoint`` and ``view --checkpoint``
    accept); a resume with nothing left to do returns the run's last logged update so.
    """
    if frames is not None:
        _check_count("frames", frames)
    # Refused before anything is written: a callback that is not one used to fail only after
    # the first update, with that update trained and saved.
    if callback is not None and not callable(callback):
        raise ValueError(
            f"callback must be callable (it is called with each update's log) or None, got {callback!r}"
        )
    if isinstance(levels, str):
        levels = _bare(levels)
    elif levels is not None:
        levels = [_bare(level) for level in levels]
    return dict(
        _core.train(
            os.fspath(out), levels, frames, resume=bool(resume), callback=callback, **settings
        )
    )


for _level in _core.level_ids():
    _register(_level)
del _level
