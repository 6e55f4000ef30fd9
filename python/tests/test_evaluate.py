"""groundscope.evaluate and groundscope.record on Python policies: the episodes they run are
minigrid's, the callable sees each episode in a fixed row, the maps it returns are graded, and
bad input leaves nothing behind."""

import csv
import json
import os

import gymnasium as gym
import numpy as np
import pytest

import groundscope
from policies import grounded, reactive, reactive_logits

LEVEL = "BabyAI-GoToLocal-v0"


def episodes(out):
    with open(os.path.join(out, "episodes.csv"), newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize(
    "level",
    [
        LEVEL,
        "BabyAI-PickupLoc-v0",
        "BabyAI-OpenDoor-v0",
        "MiniGrid-DoorKey-5x5-v0",
        "MiniGrid-Dynamic-Obstacles-6x6-v0",
        "MiniGrid-Fetch-5x5-N2-v0",
        "MiniGrid-LavaGapS5-v0",
    ],
)
def test_episodes_replay_in_minigrid(tmp_path, level):
    out = tmp_path / "run"
    report = groundscope.evaluate(reactive, [level], seeds=2, episodes=8, out=out, first_seed=3)
    rows = episodes(out)
    assert len(rows) == 16
    outcomes = set()
    assert report["cells"][0]["episodes"] == 16
    for row in rows:
        seed = int(row["level_seed"])
        assert seed == int(row["eval_seed"]) * 10**6 + int(row["episode"])
        assert int(row["eval_seed"]) in (3, 4)
        env = gym.make(level)
        obs, _ = env.reset(seed=seed)
        assert obs["mission"] == row["mission"]
        actions = [int(a) for a in row["actions"].split()]
        assert len(actions) == int(row["steps"])
        total = 0.0
        for t, a in enumerate(actions):
            # The policy chose each action from the observation minigrid shows.
            assert int(np.argmax(reactive_logits(obs["image"], obs["direction"]))) == a, (seed, t)
            obs, r, term, trunc, _ = env.step(a)
            total += r
            assert (term or trunc) == (t == len(actions) - 1), (seed, t)
        assert abs(total - float(row["return"])) < 1e-6
        assert row["success"] == ("1" if total > 0 else "0")
        outcomes.add(len(actions))
    # Episodes ended at different steps, not all truncated alike (picking up the wrong object
    # fails at once).
    assert len(outcomes) > 1 or level != "BabyAI-PickupLoc-v0"


def test_rows_stay_fixed_and_first_marks_starts(tmp_path):
    calls = []

    def act(obs, first):
        calls.append((list(obs["mission"]), first.copy(), obs["image"].shape, obs["direction"].dtype))
        return reactive(obs, first)

    groundscope.evaluate(act, [LEVEL], seeds=2, episodes=5, out=tmp_path / "run")
    missions = [r["mission"] for r in episodes(tmp_path / "run")]
    assert len(calls) > 1
    for k, (m, first, shape, dtype) in enumerate(calls):
        assert m == missions
        assert shape == (10, 7, 7, 3) and dtype == np.int64
        assert first.dtype == np.bool_ and first.tolist() == [k == 0] * 10


def test_grounded_maps_score_and_a_wrong_layout_does_not(tmp_path):
    right = groundscope.evaluate(grounded, [LEVEL], seeds=1, episodes=20, out=tmp_path / "a")
    acc = right["cells"][0]["accuracy"]
    assert right["checkpoints"][0]["variant"] == "attention"
    assert acc["object"]["acc"]["mean"] > 0.99
    assert acc["color"]["acc"]["mean"] > 0.99
    # The same maps read as agent-up are transposed: they miss most objects.
    wrong = groundscope.evaluate(
        grounded, [LEVEL], seeds=1, episodes=20, out=tmp_path / "b", map_layout="agent-up"
    )
    assert wrong["cells"][0]["accuracy"]["object"]["acc"]["mean"] < 0.6
    # Maps given agent-up and declared so score as the image-order ones.
    up = groundscope.evaluate(
        lambda o, f: grounded(o, f, layout="agent-up"),
        [LEVEL],
        seeds=1,
        episodes=20,
        out=tmp_path / "c",
        map_layout="agent-up",
    )
    assert up["cells"][0]["accuracy"] == acc
    with open(tmp_path / "a" / "words.csv") as f:
        assert "ball" in f.read()


def test_report_files_as_the_cli_writes_them(tmp_path):
    out = tmp_path / "run"
    report = groundscope.evaluate(
        reactive, [LEVEL, "groundscope-PaperLocalS8N4-v0"], seeds=1, episodes=4, out=out
    )
    for name in ("report.md", "report.json", "episodes.csv", "performance.csv", "levels_success.png"):
        assert (out / name).stat().st_size > 0, name
    assert json.loads((out / "report.json").read_text()) == report
    assert report["checkpoints"][0]["variant"] == "baseline"
    assert [c["episodes"] for c in report["cells"]] == [4, 4]
    levels = {r["level"] for r in episodes(out)}
    assert levels == {LEVEL, "groundscope-PaperLocalS8N4-v0"}
    md = (out / "report.md").read_text()
    assert "python" in md


def test_a_python_policys_report_invents_no_training_facts_and_gives_runnable_replays(tmp_path):
    out = tmp_path / "run"
    report = groundscope.evaluate(reactive, [LEVEL], seeds=1, episodes=6, out=out, top_k=3)
    ckpt = report["checkpoints"][0]
    # Its training is its own: not known here, and said so (it used to read "0 training
    # frames, trained on <the first level evaluated>").
    assert ckpt["frames"] is None and ckpt["level"] is None
    md = (out / "report.md").read_text()
    assert "training frames not known" in md and "training levels not known" in md
    assert "0 training frames" not in md
    failures = json.loads((out / "failures.json").read_text())
    assert failures, "the reactive policy fails some GoToLocal episodes"
    for f in failures:
        # The replay is a Python call that runs as written (with `act` the policy), and the
        # episode opens in the Rerun viewer on the file it writes; no CLI flag glued to it.
        call = f["replay"]
        assert call.startswith(f'groundscope.record(act, "{LEVEL}", {f["seed"]}, "'), call
        assert "--step" not in md.split(call)[1].split("\n")[0]
        path = tmp_path / f"{LEVEL}-seed{f['seed']}.rrd"
        act = reactive  # noqa: F841  (the name the call uses)
        ok, steps, _ = eval(call.replace('"' + path.name + '"', repr(str(path))))
        assert path.stat().st_size > 0 and steps == f["length"]
        assert f"rerun {path.name}" in md


def test_the_callables_exception_propagates_and_nothing_is_written(tmp_path):
    def broken(obs, first):
        raise KeyError("no such head")

    with pytest.raises(KeyError, match="no such head"):
        groundscope.evaluate(broken, [LEVEL], seeds=1, episodes=2, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    "output, word",
    [
        (lambda n: np.zeros((n, 6), np.float32), "logits"),
        (lambda n: np.full((n, 7), np.nan, np.float32), "non-finite"),
        (lambda n: {"word_maps": np.zeros((n, 9, 7, 7))}, "logits"),
        (lambda n: {"logits": np.zeros((n, 7)), "word_maps": np.zeros((n, 1, 7, 7))}, "word_maps"),
        (lambda n: {"logits": np.zeros((n, 7)), "word_maps": -np.ones((n, 9, 7, 7))}, "negative"),
        (lambda n: "left", "logits"),
        # All-ones maps used to score acc = acc_ng = 1.0: maps are distributions, or refused.
        (lambda n: {"logits": np.zeros((n, 7)), "word_maps": np.ones((n, 9, 7, 7))}, "sums to 49"),
        (lambda n: {"logits": np.zeros((n, 7)), "combined_map": np.ones((n, 7, 7)),
                    "word_maps": np.full((n, 9, 7, 7), 1 / 49)}, "combined_map"),
        # A misspelt key used to drop its output in silence.
        (lambda n: {"logits": np.zeros((n, 7)), "wordmaps": np.zeros((n, 9, 7, 7))},
         'unknown key "wordmaps".*did you mean "word_maps"'),
    ],
)
def test_bad_outputs_are_one_line_value_errors(tmp_path, output, word):
    with pytest.raises(ValueError, match=word) as e:
        groundscope.evaluate(
            lambda o, f: output(len(o["mission"])), [LEVEL], seeds=1, episodes=2, out=tmp_path / "r"
        )
    assert "\n" not in str(e.value)
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"levels": ["BabyAI-GoToLocl-v0"]}, "GoToLocal"),
        ({"levels": []}, "levels"),
        ({"seeds": 0}, "seeds"),
        ({"episodes": 10**6}, "episodes"),
        ({"first_seed": 2147}, "first_seed"),
        ({"map_layout": "xy"}, "map_layout"),
        # Past 64 bits: named, where they used to be OverflowErrors naming nothing.
        ({"first_seed": 2**64}, "first_seed"),
        ({"seeds": 2**64}, "seeds"),
        ({"episodes": 2**70}, "episodes"),
        ({"top_k": 2**64}, "top_k"),
    ],
)
def test_bad_arguments_are_refused_before_running(tmp_path, kwargs, word):
    called = []
    args = {"levels": [LEVEL], "seeds": 1, "episodes": 2, "out": tmp_path / "r"} | kwargs
    with pytest.raises(ValueError, match=word):
        groundscope.evaluate(lambda o, f: called.append(1), **args)
    assert not called and not (tmp_path / "r").exists()


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"first_seed": 2**64}, "first_seed"),
        ({"seeds": -1}, "seeds"),
        ({"episodes": 2**64}, "episodes"),
        ({"top_k": -1}, "top_k"),
    ],
)
def test_the_rust_functions_name_out_of_range_ints(tmp_path, kwargs, word):
    called = []
    args = {"seeds": 1, "episodes": 2, "out": os.fspath(tmp_path / "r")} | kwargs
    with pytest.raises(ValueError, match=word):
        groundscope._core.evaluate(lambda o, f: called.append(1), [LEVEL], **args)
    assert not called and not (tmp_path / "r").exists()
    with pytest.raises(ValueError, match="seed"):
        groundscope._core.record(reactive, LEVEL, 2**64, os.fspath(tmp_path / "ep.rrd"))
    assert list(tmp_path.iterdir()) == []


def test_record_writes_rerun_and_mcap_with_word_maps(tmp_path):
    seed = 4
    rrd = tmp_path / "ep.rrd"
    success, steps, reward = groundscope.record(grounded, LEVEL, seed, rrd)
    assert rrd.read_bytes()[:4] == b"RRF2"
    # The same episode as evaluate runs for that level seed.
    groundscope.evaluate(grounded, [LEVEL], seeds=1, episodes=seed + 1, out=tmp_path / "run")
    row = episodes(tmp_path / "run")[seed]
    assert (int(row["steps"]), row["success"]) == (steps, "1" if success else "0")
    assert abs(float(row["return"]) - reward) < 1e-6
    with_maps = tmp_path / "maps.mcap"
    without = tmp_path / "plain.mcap"
    groundscope.record(grounded, LEVEL, seed, with_maps)
    groundscope.record(reactive, LEVEL, seed, without)
    assert with_maps.read_bytes()[:8] == b"\x89MCAP0\r\n"
    assert b"/attention/words/" in with_maps.read_bytes()
    assert b"/attention/words/" not in without.read_bytes()


def test_record_takes_minigrid_ids_and_classes(tmp_path):
    for level in ("MiniGrid-Dynamic-Obstacles-5x5-v0", "MultiRoomEnv(minNumRooms=2, maxNumRooms=2)"):
        rrd = tmp_path / "mg.rrd"
        success, steps, reward = groundscope.record(reactive, level, 1, rrd)
        assert rrd.read_bytes()[:4] == b"RRF2"
        assert steps >= 1


def test_record_refuses_bad_paths_and_levels(tmp_path):
    with pytest.raises(ValueError, match=r"\.rrd"):
        groundscope.record(reactive, LEVEL, 0, tmp_path / "ep.txt")
    with pytest.raises(ValueError, match="GoToLocal"):
        groundscope.record(reactive, "BabyAI-GoToLocl-v0", 0, tmp_path / "ep.rrd")
    with pytest.raises(ValueError, match="seed"):
        groundscope.record(reactive, LEVEL, -1, tmp_path / "ep.rrd")
    with pytest.raises(ValueError, match="seed"):
        groundscope.record(reactive, LEVEL, 2**64, tmp_path / "ep.rrd")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["bot", "python", "bundled:attention"])
def test_a_python_policys_report_is_not_reopened_as_a_checkpoint(tmp_path, name):
    """`view --report` on a Python policy's report opens it read-only, its episodes replayed
    from the actions the report holds: nothing is loaded under the policy's name (it used to
    fail on "python.json: No such file or directory", and a policy named "bot" opened
    minigrid's bot instead), so without a display the only error left is the window's."""
    import subprocess

    from conftest import find_groundscope_bin

    out = tmp_path / "run"
    report = groundscope.evaluate(reactive, [LEVEL], seeds=1, episodes=2, out=out, name=name)
    assert report["checkpoints"][0]["python"] is True
    exe = find_groundscope_bin()
    if exe is None:
        pytest.fail("no groundscope binary: build it (cargo build --release) or set GROUNDSCOPE_BIN")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    done = subprocess.run(
        [exe, "view", "--report", str(out)], capture_output=True, text=True, env=env, timeout=120
    )
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "no display" in done.stderr, done.stderr
    assert "Python policy" not in done.stderr and name + ".json" not in done.stderr, done.stderr
    # What the debugger replays: each episode's actions, one per step.
    with open(out / "episodes.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows and all(r["checkpoint"] == name for r in rows)
    assert all(len(r["actions"].split()) == int(r["steps"]) for r in rows), rows


def test_every_babyai_level_evaluates_with_word_maps(tmp_path):
    """Every level's missions reach the callable and are graded: no word outside the
    vocabulary, maps long enough for the longest missions (BossLevel's)."""
    report = groundscope.evaluate(grounded, groundscope.level_ids(), seeds=1, episodes=2, out=tmp_path / "all")
    assert [c["level"] for c in report["cells"]] == groundscope.level_ids()
    assert all(c["episodes"] == 2 for c in report["cells"])
    assert len(episodes(tmp_path / "all")) == 2 * len(groundscope.level_ids()) == 2 * 172
