"""Type stubs of groundscope._core, the Rust extension (python/src/). The public API is
groundscope's own (``groundscope.make``, ``make_vec``, ``evaluate``, ``record``); these are the
calls it makes."""

from os import PathLike
from typing import Any, Callable, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

MINIGRID_VERSION: str

def level_ids() -> list[str]: ...

class Env:
    def __init__(self, id: str) -> None: ...
    def reset(
        self, seed: Optional[int] = None
    ) -> tuple[npt.NDArray[np.uint8], int, str]: ...
    def step(
        self, action: int
    ) -> tuple[npt.NDArray[np.uint8], int, str, float, bool, bool]: ...
    @property
    def level(self) -> str: ...
    @property
    def max_steps(self) -> Optional[int]: ...
    @property
    def step_count(self) -> Optional[int]: ...
    @property
    def agent_pos(self) -> Optional[tuple[int, int]]: ...

class VecEnv:
    def __init__(self, id: str, num_envs: int, num_threads: int = 0) -> None: ...
    def reset(
        self,
        seeds: Sequence[Optional[int]],
        image: npt.NDArray[np.uint8],
        direction: npt.NDArray[np.int64],
        mask: Optional[npt.NDArray[np.bool_]] = None,
    ) -> list[str]: ...
    def step(
        self,
        actions: npt.NDArray[np.int64],
        image: npt.NDArray[np.uint8],
        direction: npt.NDArray[np.int64],
        reward: npt.NDArray[np.float64],
        terminated: npt.NDArray[np.bool_],
        truncated: npt.NDArray[np.bool_],
    ) -> list[tuple[int, str]]: ...
    @property
    def level(self) -> str: ...
    @property
    def num_envs(self) -> int: ...
    @property
    def num_threads(self) -> int: ...
    @property
    def max_steps(self) -> list[int]: ...

def evaluate(
    act: Callable[[dict[str, Any], npt.NDArray[np.bool_]], Any],
    levels: Sequence[str],
    seeds: int = 5,
    episodes: int = 100,
    out: Union[str, PathLike[str]] = "run",
    first_seed: int = 0,
    sample: bool = False,
    alpha: float = 0.5,
    name: str = "python",
    map_layout: str = "image",
    top_k: int = 10,
) -> str: ...
def record(
    act: Callable[[dict[str, Any], npt.NDArray[np.bool_]], Any],
    level: str,
    seed: int,
    path: Union[str, PathLike[str]],
    sample: bool = False,
    alpha: float = 0.5,
    name: str = "python",
    map_layout: str = "image",
) -> tuple[bool, int, float]: ...
def train(
    out: Union[str, PathLike[str]],
    levels: Union[str, Sequence[str], None] = None,
    frames: Optional[int] = None,
    *,
    resume: bool = False,
    callback: Optional[Callable[[dict[str, Any]], Any]] = None,
    model: Optional[str] = None,
    hidden: Optional[int] = None,
    seed: Optional[int] = None,
    init: Optional[str] = None,
    procs: Optional[int] = None,
    frames_per_proc: Optional[int] = None,
    epochs: Optional[int] = None,
    batch_size: Optional[int] = None,
    recurrence: Optional[int] = None,
    lr: Optional[float] = None,
    adam_eps: Optional[float] = None,
    discount: Optional[float] = None,
    gae_lambda: Optional[float] = None,
    entropy_coef: Optional[float] = None,
    value_loss_coef: Optional[float] = None,
    max_grad_norm: Optional[float] = None,
    clip_eps: Optional[float] = None,
    threads: Optional[int] = None,
    reward_scale: Optional[float] = None,
    normalize_advantages: Optional[bool] = None,
    imitate: Optional[bool] = None,
    imitate_policy_share: Optional[float] = None,
    teacher: Optional[Union[str, Sequence[str]]] = None,
    ground_loss: Optional[float] = None,
    word_temperature_anneal: Optional[str] = None,
    freeze_attention_at: Optional[int] = None,
    eval_interval: Optional[int] = None,
    eval_episodes: Optional[int] = None,
    save_interval: Optional[int] = None,
) -> dict[str, Any]: ...
