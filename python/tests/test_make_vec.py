"""groundscope.make_vec against gymnasium.make_vec(..., vectorization_mode="sync") over
minigrid 3.2.0, step by step, autoresets included."""

import os
import zlib

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import groundscope
from conftest import BABYAI_IDS, MINIGRID_IDS, assert_batch_equal

NUM_ENVS = 4
STEPS = 80

# Summed over every id: the comparison must have crossed episode ends.
_autoresets = []


@pytest.mark.parametrize("env_id", BABYAI_IDS + MINIGRID_IDS)
def test_make_vec_equals_sync_vector_env(env_id):
    ref = gym.make_vec(env_id, NUM_ENVS, vectorization_mode="sync")
    ours = groundscope.make_vec(env_id, NUM_ENVS, num_threads=2)
    assert ours.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert ours.num_envs == ref.num_envs
    assert ours.action_space == ref.action_space
    rng = np.random.default_rng(zlib.crc32(env_id.encode()))
    seed = 11
    o_ref, i_ref = ref.reset(seed=seed)
    o, i = ours.reset(seed=seed)
    assert i == i_ref == {}
    assert_batch_equal(o, o_ref, f"{env_id} reset(seed={seed})")
    resets = 0
    ended = np.zeros(NUM_ENVS, bool)
    for t in range(STEPS):
        a = rng.integers(0, 7, NUM_ENVS)
        o_ref, r_ref, term_ref, trunc_ref, i_ref = ref.step(a)
        o, r, term, trunc, i = ours.step(a)
        where = f"{env_id} step {t} actions {a.tolist()}"
        assert_batch_equal(o, o_ref, where)
        assert r.dtype == r_ref.dtype and term.dtype == term_ref.dtype == trunc.dtype
        np.testing.assert_array_equal(r, r_ref, err_msg=where)
        np.testing.assert_array_equal(term, term_ref, err_msg=where)
        np.testing.assert_array_equal(trunc, trunc_ref, err_msg=where)
        assert i == i_ref == {}
        # The step after an end is the reset step: reward 0, both flags false.
        assert not r[ended].any() and not term[ended].any() and not trunc[ended].any()
        resets += int(ended.sum())
        ended = term | trunc
    _autoresets.append(resets)
    ref.close()
    ours.close()


def test_the_comparison_crossed_autoresets():
    if len(_autoresets) < len(BABYAI_IDS) + len(MINIGRID_IDS):
        pytest.skip("needs the whole comparison above")
    assert sum(_autoresets) >= 50, _autoresets


def test_threads_do_not_change_results():
    env_id = "BabyAI-GoToLocal-v0"
    a = groundscope.make_vec(env_id, 16, num_threads=1)
    b = groundscope.make_vec(env_id, 16, num_threads=3)
    assert (a.num_threads, b.num_threads) == (1, 3)
    oa, _ = a.reset(seed=0)
    ob, _ = b.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(200):
        act = rng.integers(0, 7, 16)
        oa, ra, ta, ua, _ = a.step(act)
        ob, rb, tb, ub, _ = b.step(act)
        assert_batch_equal(oa, ob, "threads")
        np.testing.assert_array_equal(ra, rb)
        np.testing.assert_array_equal(ta | ua, tb | ub)


def test_default_threads_follow_the_vector_size():
    assert groundscope.make_vec("BabyAI-GoToLocal-v0", 64).num_threads == 1
    many = groundscope.make_vec("BabyAI-GoToLocal-v0", 1024).num_threads
    assert many == min(os.cpu_count(), 4)


def test_seed_lists_none_and_reset_mask_follow_gymnasium():
    env_id = "BabyAI-PickupLoc-v0"
    ref = gym.make_vec(env_id, 3, vectorization_mode="sync")
    ours = groundscope.make_vec(env_id, 3)
    assert_batch_equal(ours.reset(seed=[5, 9, 2])[0], ref.reset(seed=[5, 9, 2])[0], "list")
    # Without a seed every env continues its own generator.
    assert_batch_equal(ours.reset()[0], ref.reset()[0], "no seed")
    mask = np.array([True, False, True])
    o, _ = ours.reset(seed=[1, 2, 3], options={"reset_mask": mask})
    o_ref, _ = ref.reset(seed=[1, 2, 3], options={"reset_mask": mask})
    assert_batch_equal(o, o_ref, "reset_mask")


def test_observations_are_copies_unless_asked():
    envs = groundscope.make_vec("BabyAI-GoToLocal-v0", 2)
    first, _ = envs.reset(seed=0)
    kept = first["image"].copy()
    envs.step(np.array([0, 1]))
    np.testing.assert_array_equal(first["image"], kept)
    shared = groundscope.make_vec("BabyAI-GoToLocal-v0", 2, copy=False)
    o1, _ = shared.reset(seed=0)
    o2, *_ = shared.step(np.array([0, 1]))
    assert o1["image"] is o2["image"]


def test_bad_inputs_are_one_line_errors_and_change_nothing():
    with pytest.raises(ValueError, match="num_envs"):
        groundscope.make_vec("BabyAI-GoToLocal-v0", 0)
    with pytest.raises(ValueError, match="GoToLocal"):
        groundscope.make_vec("BabyAI-GoToLocl-v0", 2)
    envs = groundscope.make_vec("BabyAI-GoToLocal-v0", 3)
    with pytest.raises(RuntimeError, match="reset"):
        envs.step(np.zeros(3, np.int64))
    with pytest.raises(ValueError, match="seed"):
        envs.reset(seed=[1, 2])
    with pytest.raises(ValueError, match=r"seed\[1\]"):
        envs.reset(seed=[1, -2, 3])
    envs.reset(seed=0)
    ref = groundscope.make_vec("BabyAI-GoToLocal-v0", 3)
    ref.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions\[2\]"):
        envs.step(np.array([2, 2, 9]))
    with pytest.raises(ValueError, match="shape"):
        envs.step(np.array([2, 2]))
    with pytest.raises(ValueError, match="integers"):
        envs.step(np.array([2.0, 2.0, 2.0]))
    # Past 64 bits (numpy keeps them as objects) or past int64: named, not an OverflowError
    # nor wrapped round to another action.
    with pytest.raises(ValueError, match=r"actions\[1\]"):
        envs.step([2, 2**70, 2])
    with pytest.raises(ValueError, match=r"actions\[0\]"):
        envs.step([-(2**70), 2, 2])
    with pytest.raises(ValueError, match=r"actions\[2\]"):
        envs.step(np.array([2, 2, 2**63], np.uint64))
    # None of the refused steps moved an env.
    o, *_ = envs.step(np.array([2, 2, 2]))
    o_ref, *_ = ref.step(np.array([2, 2, 2]))
    assert_batch_equal(o, o_ref, "after refused steps")


def test_sizes_past_memory_and_thread_bounds_are_refused_not_aborted():
    # 10**12 envs used to abort the interpreter on allocation; 20000 threads used to hang.
    with pytest.raises(ValueError, match="num_envs must be at most"):
        groundscope.make_vec("BabyAI-GoToLocal-v0", 10**12)
    with pytest.raises(ValueError, match="num_threads must be at most"):
        groundscope.make_vec("BabyAI-GoToLocal-v0", 4, num_threads=20000)
    # Past 64 bits: a ValueError naming the argument, not an OverflowError.
    with pytest.raises(ValueError, match="num_envs"):
        groundscope.make_vec("BabyAI-GoToLocal-v0", 2**64)
    with pytest.raises(ValueError, match="num_threads"):
        groundscope.make_vec("BabyAI-GoToLocal-v0", 4, num_threads=2**64)
    envs = groundscope.make_vec("BabyAI-GoToLocal-v0", 4, num_threads=64)
    envs.reset(seed=0)
    envs.step(np.zeros(4, np.int64))
