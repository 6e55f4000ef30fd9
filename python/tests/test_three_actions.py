"""A Python policy that scores only MiniGrid's first three actions (left, right, forward), as
Dynamic-Obstacles' and many lava agents are trained: logits (N, 3) run the same episodes as a
plain gymnasium + minigrid loop driving the callable, sampling draws among those three only,
and a width that changes between calls or is neither 3 nor 7 is a one-line ValueError."""

import csv
import os

import gymnasium as gym
import numpy as np
import pytest

import groundscope
from policies import three_actions

LEVEL = "MiniGrid-Dynamic-Obstacles-5x5-v0"


def episodes(out):
    with open(os.path.join(out, "episodes.csv"), newline="") as f:
        return list(csv.DictReader(f))


def minigrid_episode(act, level, seed):
    """`act` driving minigrid's own env from level seed `seed`, greedy, one row a call:
    the actions taken and the return."""
    env = gym.make(level)
    obs, _ = env.reset(seed=seed)
    actions, total = [], 0.0
    while True:
        batch = {
            "image": obs["image"][None],
            "direction": np.array([obs["direction"]], np.int64),
            "mission": [obs["mission"]],
        }
        logits = np.asarray(act(batch, np.array([not actions])))
        assert logits.shape == (1, 3)
        a = int(np.argmax(logits[0]))
        actions.append(a)
        obs, r, term, trunc, _ = env.step(a)
        total += r
        if term or trunc:
            return actions, total


def test_a_three_action_policys_episodes_are_minigrids(tmp_path):
    out = tmp_path / "run"
    report = groundscope.evaluate(three_actions, [LEVEL], seeds=2, episodes=10, out=out)
    rows = episodes(out)
    assert report["cells"][0]["episodes"] == len(rows) == 20
    for row in rows:
        seed = int(row["level_seed"])
        assert seed == int(row["eval_seed"]) * 10**6 + int(row["episode"])
        actions, total = minigrid_episode(three_actions, LEVEL, seed)
        assert [int(a) for a in row["actions"].split()] == actions, seed
        assert int(row["steps"]) == len(actions), seed
        assert abs(float(row["return"]) - total) < 1e-6, seed
        assert row["success"] == ("1" if total > 0 else "0"), seed
    taken = {int(a) for row in rows for a in row["actions"].split()}
    assert 2 in taken and taken <= {0, 1, 2}, taken


def test_record_runs_the_same_three_action_episode(tmp_path):
    for seed, path in ((3, tmp_path / "ep.rrd"), (5, tmp_path / "ep.mcap")):
        success, steps, reward = groundscope.record(three_actions, LEVEL, seed, path)
        actions, total = minigrid_episode(three_actions, LEVEL, seed)
        assert (steps, success) == (len(actions), total > 0), seed
        assert abs(reward - total) < 1e-6, seed
        assert path.stat().st_size > 0


def uniform(width):
    """Equal logits over `width` actions: a sampled run draws every one of them."""
    return lambda obs, first: np.zeros((len(obs["mission"]), width), np.float32)


def test_sampled_actions_are_drawn_among_the_three_scored(tmp_path):
    level = "MiniGrid-Empty-5x5-v0"
    taken = {}
    for width in (3, 7):
        out = tmp_path / f"w{width}"
        groundscope.evaluate(uniform(width), [level], seeds=1, episodes=8, out=out, sample=True)
        taken[width] = [int(a) for row in episodes(out) for a in row["actions"].split()]
    assert len(taken[3]) > 50 and set(taken[3]) == {0, 1, 2}
    # The same draw over 7 logits does take the others: the 3 come from the width.
    assert max(taken[7]) > 2


def test_a_width_that_changes_between_calls_is_refused(tmp_path):
    calls = []

    def act(obs, first):
        calls.append(1)
        return np.zeros((len(obs["mission"]), 3 if len(calls) == 1 else 7), np.float32)

    # Always left: the episodes run past the first step.
    with pytest.raises(ValueError, match="7 logits per row after 3") as e:
        groundscope.evaluate(act, [LEVEL], seeds=1, episodes=2, out=tmp_path / "r")
    assert "\n" not in str(e.value) and len(calls) == 2
    assert not (tmp_path / "r").exists()
    calls.clear()
    with pytest.raises(ValueError, match="7 logits per row after 3"):
        groundscope.record(act, LEVEL, 0, tmp_path / "ep.rrd")
    assert not (tmp_path / "ep.rrd").exists()


@pytest.mark.parametrize("width", [5, 1, 6])
def test_a_width_neither_3_nor_7_is_refused_naming_both(tmp_path, width):
    with pytest.raises(ValueError, match=r"\(N, 3\) or \(N, 7\)") as e:
        groundscope.evaluate(uniform(width), [LEVEL], seeds=1, episodes=2, out=tmp_path / "r")
    assert "\n" not in str(e.value) and f", {width}]" in str(e.value)
    assert not (tmp_path / "r").exists()
    with pytest.raises(ValueError, match=r"\(N, 3\) or \(N, 7\)"):
        groundscope.record(uniform(width), LEVEL, 0, tmp_path / "ep.mcap")
    assert not (tmp_path / "ep.mcap").exists()
