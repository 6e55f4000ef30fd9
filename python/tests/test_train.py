"""groundscope.train: the core's training run from Python — a new run, a resume, a warm
start, a callback that stops it, and bad input refused before anything is written."""

import csv
import os
import subprocess

import pytest

import groundscope
from conftest import find_groundscope_bin

# Small enough for a few seconds on 2 cores: 2 processes × 16 frames an update, batch 16.
TINY = dict(procs=2, frames_per_proc=16, batch_size=16, hidden=16, eval_interval=0)
LEVEL = "BabyAI-GoToObjS4-v0"


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_a_new_run_trains_saves_and_resumes_where_it_stopped(tmp_path):
    out = tmp_path / "run"
    log = groundscope.train(out, LEVEL, frames=64, seed=3, **TINY)
    assert log["frames"] == 64 and log["update"] == 2
    assert 0.0 <= log["success_rate"] <= 1.0
    assert os.path.isfile(os.path.join(log["checkpoint"], "model.safetensors"))
    assert [int(r["frames"]) for r in rows(out / "log.csv")] == [32, 64]
    # The run keeps its own settings on resume: it goes on from frame 64.
    seen = []
    log = groundscope.train(out, frames=128, resume=True, callback=seen.append)
    assert [d["frames"] for d in seen] == [96, 128]
    assert log["frames"] == 128
    assert [int(r["frames"]) for r in rows(out / "log.csv")] == [32, 64, 96, 128]


def test_resume_and_the_command_line_share_the_run(tmp_path):
    out = tmp_path / "run"
    groundscope.train(out, LEVEL, frames=32, seed=3, **TINY)
    exe = find_groundscope_bin()
    if exe is None:
        pytest.fail("no groundscope binary: build it (cargo build --release) or set GROUNDSCOPE_BIN")
    done = subprocess.run(
        [exe, "train", "--out", str(out), "--resume", "--frames", "64", "--quiet"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert [int(r["frames"]) for r in rows(out / "log.csv")] == [32, 64]


def test_a_callback_returning_false_stops_the_run_saved(tmp_path):
    out = tmp_path / "run"
    log = groundscope.train(out, LEVEL, frames=320, callback=lambda d: d["update"] < 3, **TINY)
    assert log["update"] == 3 and log["frames"] == 96
    # Saved where it stopped: a resume goes on from update 3.
    log = groundscope.train(out, frames=128, resume=True)
    assert log["update"] == 4


def test_a_callback_that_raises_stops_saved_and_raises(tmp_path):
    out = tmp_path / "run"

    def boom(d):
        if d["update"] == 2:
            raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        groundscope.train(out, LEVEL, frames=320, **TINY, callback=boom)
    assert [int(r["frames"]) for r in rows(out / "log.csv")] == [32, 64]
    assert groundscope.train(out, frames=96, resume=True)["frames"] == 96


def test_a_warm_start_from_a_bundled_checkpoint(tmp_path):
    log = groundscope.train(
        tmp_path / "child",
        "BabyAI-GoToLocal-v0",
        frames=10_442_752 + 32,
        init="bundled:babyai",
        imitate=True,
        procs=2,
        frames_per_proc=16,
        batch_size=16,
        eval_interval=0,
    )
    assert log["frames"] == 10_442_752 + 32


@pytest.mark.parametrize(
    "kwargs, what",
    [
        (dict(levels="BabyAI-NoSuchLevel-v0"), "NoSuchLevel"),
        (dict(levels=LEVEL, model="transformer"), "transformer"),
        (dict(levels=LEVEL, batch_size=7), "batch"),
        (dict(levels=LEVEL, save_interval=0), "save_interval"),
        (dict(levels=LEVEL, init="no/such/run"), "init"),
        (dict(levels=LEVEL, init="bundled:babyai", hidden=16), "hidden"),
        (dict(), "levels"),
        (dict(levels=[]), "level"),
    ],
)
def test_bad_input_is_a_value_error_and_writes_nothing(tmp_path, kwargs, what):
    out = tmp_path / "run"
    merged = {**dict(procs=2, frames_per_proc=16, batch_size=16, eval_interval=0), **kwargs}
    with pytest.raises(ValueError, match=what):
        groundscope.train(out, frames=32, **merged)
    assert not out.exists()


def test_a_held_directory_and_a_resume_with_settings_are_refused(tmp_path):
    out = tmp_path / "run"
    groundscope.train(out, LEVEL, frames=32, **TINY)
    before = sorted(os.listdir(out))
    with pytest.raises(ValueError, match="resume=True"):
        groundscope.train(out, LEVEL, frames=64, **TINY)
    with pytest.raises(ValueError, match="leave out lr"):
        groundscope.train(out, frames=64, resume=True, lr=0.1)
    with pytest.raises(ValueError, match="resume"):
        groundscope.train(tmp_path / "empty", frames=64, resume=True)
    assert sorted(os.listdir(out)) == before
    assert [int(r["frames"]) for r in rows(out / "log.csv")] == [32]


@pytest.mark.parametrize(
    "kwargs, what",
    [
        (dict(hidden=-1), "hidden"),
        (dict(seed=-1), "seed"),
        (dict(seed=2**64), "seed"),
        (dict(procs=-2), "procs"),
        (dict(batch_size=2**70), "batch_size"),
        (dict(save_interval=-1), "save_interval"),
        (dict(frames=2**64), "frames"),
    ],
)
def test_out_of_range_ints_are_value_errors_naming_them(tmp_path, kwargs, what):
    out = tmp_path / "run"
    args = {**TINY, "frames": 32, **kwargs}
    # They used to be OverflowErrors naming no argument ("can't convert negative int to
    # unsigned"), from the wrapper and from the Rust function alike.
    with pytest.raises(ValueError, match=what):
        groundscope.train(out, LEVEL, **args)
    frames = args.pop("frames")
    with pytest.raises(ValueError, match=what):
        groundscope._core.train(os.fspath(out), LEVEL, frames, **args)
    assert not out.exists()


def test_a_callback_that_cannot_be_called_is_refused_before_anything_is_written(tmp_path):
    out = tmp_path / "run"
    # It used to train and save an update, then raise TypeError ("'int' object is not
    # callable").
    with pytest.raises(ValueError, match="callback"):
        groundscope.train(out, LEVEL, frames=32, callback=5, **TINY)
    assert not out.exists()
    with pytest.raises(ValueError, match="callback"):
        groundscope._core.train(os.fspath(out), LEVEL, 32, callback="log", **TINY)
    assert not out.exists()
    # Nor on resume: the run stays as it was.
    groundscope.train(out, LEVEL, frames=32, **TINY)
    before = (out / "log.csv").read_text()
    with pytest.raises(ValueError, match="callback"):
        groundscope.train(out, frames=64, resume=True, callback=[])
    assert (out / "log.csv").read_text() == before


def test_a_resume_with_nothing_to_do_returns_the_last_log(tmp_path):
    out = tmp_path / "run"
    trained = groundscope.train(out, LEVEL, frames=64, seed=3, **TINY)
    again = groundscope.train(out, frames=32, resume=True)
    # The same keys as a call that trains (it used to return {'checkpoint'} alone), and the
    # values of the run's last logged update.
    assert set(again) == set(trained)
    assert again["checkpoint"] == trained["checkpoint"]
    last = rows(out / "log.csv")[-1]
    assert (again["update"], again["frames"]) == (2, 64) == (int(last["update"]), int(last["frames"]))
    assert again["episodes"] == int(last["episodes"])
    for key in ("mean_reward", "mean_length", "entropy", "policy_loss", "value_loss"):
        assert again[key] == pytest.approx(float(last[key]), nan_ok=True), key
        assert again[key] == pytest.approx(trained[key], abs=0.01, nan_ok=True), key
    assert again["ground_loss"] == 0.0 and again["fps"] == 0.0
    assert [int(r["frames"]) for r in rows(out / "log.csv")] == [32, 64]


def test_imitation_on_a_level_the_bot_cannot_label_is_refused_naming_it(tmp_path):
    out = tmp_path / "run"
    # The bot gives up at once on KeyInBox (its key is hidden in a box): the run would learn
    # from no labelled frame. It used to train on nothing without a word, as the command
    # line does not.
    with pytest.raises(ValueError, match="BabyAI-KeyInBox-v0"):
        groundscope.train(out, "BabyAI-KeyInBox-v0", frames=32, imitate=True, **TINY)
    assert not out.exists()


def test_a_teacher_labels_a_level_the_bot_cannot_and_is_the_runs_own_on_resume(tmp_path):
    level = "MiniGrid-DoorKey-5x5-v0"
    teacher = tmp_path / "teacher"
    groundscope.train(teacher, level, frames=32, **TINY)
    out = tmp_path / "student"
    # DoorKey alone is refused to the bot (it labels nothing there); a teacher labels it all.
    log = groundscope.train(
        out, level, frames=64, imitate=True, teacher=str(teacher / "model"), **TINY
    )
    assert log["frames"] == 64
    with pytest.raises(ValueError, match="teacher"):
        groundscope.train(out, frames=96, resume=True, teacher=str(teacher / "model"))
    for bad, what in [
        (dict(teacher=str(teacher / "model")), "imitate"),
        (dict(imitate=True, teacher=f"MiniGrid-Unlock-v0={teacher / 'model'}"), "MiniGrid-Unlock-v0"),
        (dict(imitate=True, teacher=3), "teacher must be"),
    ]:
        fresh = tmp_path / "refused"
        with pytest.raises(ValueError, match=what):
            groundscope.train(fresh, level, frames=32, **bad, **TINY)
        assert not fresh.exists()


def test_a_resume_names_the_keyword_it_was_given_otherwise_and_takes_the_runs_own(tmp_path):
    out = tmp_path / "run"
    groundscope.train(out, LEVEL, frames=32, seed=3, **TINY)
    before = (out / "log.csv").read_text()
    for kwargs, keyword in [
        (dict(hidden=32), "hidden"),
        (dict(entropy_coef=0.5), "entropy_coef"),
        (dict(seed=4), "seed"),
        (dict(model="baseline"), "model"),
        (dict(levels="BabyAI-GoToLocal-v0"), "levels"),
    ]:
        with pytest.raises(ValueError, match=f"leave out {keyword} "):
            groundscope.train(out, frames=64, resume=True, **kwargs)
        assert (out / "log.csv").read_text() == before, kwargs
    # The run's own values may be given again; the tracking ones may change.
    log = groundscope.train(out, LEVEL, frames=64, resume=True, seed=3, **TINY)
    assert log["frames"] == 64
    # A keyword the command has no flag for is Python's TypeError.
    with pytest.raises(TypeError, match="no_such_setting"):
        groundscope.train(out, frames=96, resume=True, no_such_setting=1)
