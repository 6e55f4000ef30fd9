"""groundscope.make against gymnasium.make over minigrid 3.2.0, step by step."""

import zlib

import gymnasium as gym
import numpy as np
import pytest

import groundscope
from conftest import BABYAI_IDS, MINIGRID_IDS, assert_obs_equal

SEEDS = (0, 7)
STEPS = 100


def test_every_babyai_and_minigrid_id_is_ported():
    assert sorted(groundscope.level_ids()) == sorted(BABYAI_IDS + MINIGRID_IDS)
    assert len(BABYAI_IDS) == 96
    assert len(MINIGRID_IDS) == 76


@pytest.mark.parametrize("env_id", BABYAI_IDS + MINIGRID_IDS)
def test_make_equals_minigrid(env_id):
    ref = gym.make(env_id)
    ours = groundscope.make(env_id)
    assert ours.action_space == ref.action_space, env_id
    rng = np.random.default_rng(zlib.crc32(env_id.encode()))
    resets = 0
    for seed in SEEDS:
        o_ref, i_ref = ref.reset(seed=seed)
        o, i = ours.reset(seed=seed)
        assert i == i_ref == {}
        assert_obs_equal(o, o_ref, f"{env_id} reset(seed={seed})")
        assert ours.unwrapped.max_steps == ref.unwrapped.max_steps
        for t in range(STEPS):
            a = int(rng.integers(0, 7))
            o_ref, r_ref, term_ref, trunc_ref, _ = ref.step(a)
            o, r, term, trunc, info = ours.step(a)
            where = f"{env_id} seed {seed} step {t} action {a}"
            assert_obs_equal(o, o_ref, where)
            assert (r, term, trunc) == (r_ref, term_ref, trunc_ref), where
            assert info == {}
            if term or trunc:
                # No seed: both continue their own generator, as minigrid's reset(seed=None).
                o_ref, _ = ref.reset()
                o, _ = ours.reset()
                assert_obs_equal(o, o_ref, f"{where}: reset without a seed")
                resets += 1
    ref.close()
    ours.close()


def test_random_actions_reach_resets_on_some_levels():
    """The comparison above covers episode ends: random actions end these levels quickly."""
    ends = 0
    for env_id in ("BabyAI-GoToRedBallGrey-v0", "BabyAI-PickupLoc-v0", "BabyAI-OneRoomS8-v0"):
        env = groundscope.make(env_id)
        env.reset(seed=1)
        rng = np.random.default_rng(0)
        for _ in range(STEPS):
            _, _, term, trunc, _ = env.step(int(rng.integers(0, 7)))
            if term or trunc:
                ends += 1
                env.reset()
    assert ends >= 3


def test_unseeded_first_reset_draws_a_level():
    env = groundscope.make("BabyAI-GoToLocal-v0")
    obs, _ = env.reset()
    assert obs["mission"].startswith("go to")


def test_the_paper_level():
    env = groundscope.make("groundscope-PaperLocalS8N4-v0")
    obs, _ = env.reset(seed=3)
    assert obs["image"].shape == (7, 7, 3)
    assert obs["mission"].split()[0] in ("go", "pick")
    # Same seed, same level.
    again, _ = groundscope.make("groundscope-PaperLocalS8N4-v0").reset(seed=3)
    assert again["mission"] == obs["mission"]
    np.testing.assert_array_equal(again["image"], obs["image"])


def test_registered_with_gymnasium():
    env = gym.make("groundscope/BabyAI-GoToLocal-v0")
    ref = gym.make("BabyAI-GoToLocal-v0")
    assert_obs_equal(env.reset(seed=5)[0], ref.reset(seed=5)[0], "gym.make")
    vec = gym.make_vec("groundscope/BabyAI-GoToLocal-v0", 3)
    assert isinstance(vec.unwrapped, groundscope.GroundscopeVecEnv)
    assert vec.reset(seed=1)[0]["image"].shape == (3, 7, 7, 3)


@pytest.mark.parametrize(
    "bad, word",
    [
        ("BabyAI-GoToLocl-v0", "BabyAI-GoToLocal-v0"),
        ("groundscope-PaperLocalS8-v0", "PaperLocal"),
        ("groundscope-PaperLocalS3N4-v0", "room_size"),
    ],
)
def test_unknown_ids_are_one_line_errors(bad, word):
    with pytest.raises(ValueError, match=word) as e:
        groundscope.make(bad)
    assert "\n" not in str(e.value)


def test_bad_inputs_raise_without_changing_the_env():
    # Unwrapped: gymnasium's passive checker trips over a first step that raised.
    env = groundscope.make("BabyAI-GoToLocal-v0").unwrapped
    with pytest.raises(ValueError, match="seed"):
        env.reset(seed=-1)
    with pytest.raises(ValueError, match="seed"):
        env.reset(seed=2**64)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    obs, _ = env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(7)
    # As minigrid, which raises ValueError("Unknown action") for each: not rounded, not parsed.
    for bad in ("left", 2.7, "2", None, [2]):
        with pytest.raises(ValueError, match="action"):
            env.step(bad)
    # The failed steps did not move the agent: the next step matches a fresh env's.
    ref = groundscope.make("BabyAI-GoToLocal-v0")
    ref.reset(seed=0)
    assert_obs_equal(env.step(2)[0], ref.step(2)[0], "after bad actions")


def test_actions_past_64_bits_are_value_errors_naming_the_action():
    env = groundscope.make("BabyAI-GoToLocal-v0").unwrapped
    env.reset(seed=0)
    # They used to be OverflowErrors ("int too big to convert") naming nothing.
    for bad in (2**70, -(2**70), 2**63, 2**200):
        with pytest.raises(ValueError, match="action"):
            env.step(bad)
        with pytest.raises(ValueError, match="action"):
            env._core.step(bad)
    # The refused steps did not move the agent.
    ref = groundscope.make("BabyAI-GoToLocal-v0")
    ref.reset(seed=0)
    assert_obs_equal(env.step(2)[0], ref.step(2)[0], "after refused actions")
    # Dynamic-Obstacles acts `left` for any action at or past 3, as its step does, any size.
    dyn = groundscope.make("MiniGrid-Dynamic-Obstacles-5x5-v0").unwrapped
    dyn.reset(seed=1)
    dyn.step(2**70)
    with pytest.raises(ValueError, match="action"):
        dyn.step(-(2**70))


def test_step_after_the_end_asks_for_reset():
    env = groundscope.make("BabyAI-GoToRedBallGrey-v0")
    env.reset(seed=0)
    done = False
    for _ in range(1000):
        _, _, term, trunc, _ = env.step(0)  # turning never succeeds: truncated at max_steps
        if term or trunc:
            done = True
            break
    assert done
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)


def test_the_package_ships_its_version_and_types():
    import importlib.resources

    assert groundscope.__version__ == "0.1.0"
    files = importlib.resources.files("groundscope")
    assert files.joinpath("py.typed").is_file()
    assert files.joinpath("_core.pyi").is_file()


@pytest.mark.parametrize(
    "cls, kwargs",
    [
        ("MultiRoomEnv", dict(minNumRooms=7, maxNumRooms=7, maxRoomSize=8)),
        ("MultiRoomEnv", dict(minNumRooms=12, maxNumRooms=12, maxRoomSize=10)),
        ("CrossingEnv", dict(size=13, num_crossings=4, obstacle_type="wall")),
        ("KeyCorridorEnv", dict(room_size=4, num_rows=4)),
        ("DoorKeyEnv", dict(size=12)),
        ("EmptyEnv", dict(size=10, agent_start_pos=None)),
        ("DynamicObstaclesEnv", dict(size=10, n_obstacles=6)),
        ("FetchEnv", dict(size=7, numObjs=4)),
        ("PutNearEnv", dict(size=7, numObjs=3)),
        ("ObstructedMaze_Full", dict(agent_room=(2, 1), num_quarters=3, num_rooms_visited=15)),
    ],
)
def test_a_class_with_arguments_equals_minigrids_class(cls, kwargs):
    import minigrid.envs

    # Python's own reprs but strings bare: (2, 1), None, wall.
    spelling = f"{cls}(" + ", ".join(f"{k}={v}" for k, v in kwargs.items()) + ")"
    ref = getattr(minigrid.envs, cls)(**kwargs)
    ours = groundscope.make(spelling)
    assert ours.action_space == ref.action_space
    rng = np.random.default_rng(5)
    for seed in (0, 1, 2):
        o_ref, _ = ref.reset(seed=seed)
        o, _ = ours.reset(seed=seed)
        assert_obs_equal(o, o_ref, f"{spelling} reset(seed={seed})")
        assert ours.unwrapped.max_steps == ref.unwrapped.max_steps
        for t in range(60):
            a = int(rng.integers(0, 7))
            o_ref, r_ref, te_ref, tr_ref, _ = ref.step(a)
            o, r, te, tr, _ = ours.step(a)
            assert_obs_equal(o, o_ref, f"{spelling} seed {seed} step {t}")
            assert (r, te, tr) == (r_ref, te_ref, tr_ref)
            if te or tr:
                break
    vec = groundscope.make_vec(spelling, 2)
    assert vec.single_action_space == ref.action_space
