"""Training runs: checkpoints, a stop signal and --resume give the arrays of an uninterrupted run,
bit for bit; held-out metrics are logged as documented; a trained map beats the initial one."""

from __future__ import annotations

import json
import os
import shutil
import signal
from dataclasses import replace

import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.harness import training
from envs.harness.checkpoint import (
    CHECKPOINT_FILE,
    OLD_CHECKPOINT_FILE,
    load_map,
    read_unit,
    write_unit,
)
from envs.harness.run_folder import RunFolderError
from envs.harness.run_state import CHECKPOINT_EVERY
from envs.harness.stopping import StopRequested
from envs.harness.training import METRICS_FILE, RunConfig, Trainer
from envs.harness.trials import learn_from, run_trial
from learners.persistence import CheckpointError
from learners.som.controller import VisuomotorSOM

from helpers import forbid_the_exact_model

SMALL = RunConfig.of(trials=60, lattice=(4, 3, 2), eval_every=20, eval_trials=10, seed=3)


def _arrays(path):
    som = VisuomotorSOM.load(path)
    return som.w, som.theta, som.A, som.t


def _train(config, out, **kw):
    trainer = Trainer(config, out)
    try:
        trainer.run(**kw)
    finally:
        trainer.close()
    return trainer


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("full")
    _train(SMALL, out, checkpoint_every=1000)
    return out


def test_resume_after_sigint_is_bit_identical(uninterrupted, tmp_path):
    def interrupt(trial, running):
        if trial == 27:
            os.kill(os.getpid(), signal.SIGINT)  # a real signal, noted by the trainer's handler

    with pytest.raises(StopRequested) as stopped:
        _train(SMALL, tmp_path, checkpoint_every=1000, progress=interrupt)
    assert stopped.value.exit_code == 130
    assert read_unit(tmp_path / CHECKPOINT_FILE)[0]["trial"] == 27
    trainer = Trainer.resume(tmp_path)
    trainer.run(checkpoint_every=1000)
    trainer.close()
    for a, b in zip(
        _arrays(uninterrupted / CHECKPOINT_FILE), _arrays(tmp_path / CHECKPOINT_FILE), strict=True
    ):
        np.testing.assert_array_equal(a, b)
    assert (tmp_path / METRICS_FILE).read_text() == (uninterrupted / METRICS_FILE).read_text()


def test_a_run_folder_of_the_old_checkpoint_name_resumes_under_it(uninterrupted, tmp_path):
    """A run written when the unit was ``som.npz``: resume reads and writes that file (no second
    checkpoint appears beside it), ends as an unbroken run does, and a fresh run refuses it."""

    def stop(trial, running):
        if trial == 27:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(StopRequested):
        _train(SMALL, tmp_path, checkpoint_every=1000, progress=stop)
    old = tmp_path / OLD_CHECKPOINT_FILE
    (tmp_path / CHECKPOINT_FILE).rename(old)
    trainer = Trainer.resume(tmp_path)
    trainer.run(checkpoint_every=1000)
    trainer.close()
    assert not (tmp_path / CHECKPOINT_FILE).exists()
    for a, b in zip(_arrays(uninterrupted / CHECKPOINT_FILE), _arrays(old), strict=True):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(RunFolderError, match=OLD_CHECKPOINT_FILE):
        Trainer(SMALL, tmp_path)


def test_resume_after_a_crash_redoes_from_the_last_periodic_checkpoint(tmp_path):
    """A crash leaves the checkpoint of trial 20 and metrics up to trial 30 with a torn last
    line; the resumed run drops both and ends as an unbroken run does."""
    config = replace(SMALL, trials=40, eval_every=10)
    reference = _train(config, tmp_path / "reference", checkpoint_every=20).out

    def crash(trial, running):
        if trial == 35:
            raise RuntimeError("power cut")

    with pytest.raises(RuntimeError):
        _train(config, tmp_path / "crashed", checkpoint_every=20, progress=crash)
    with open(tmp_path / "crashed" / METRICS_FILE, "a") as f:
        f.write('{"trial": 40, "lea')  # a write cut short by a full disk
    stale = tmp_path / "crashed" / ".checkpoint.npz.x1y2.tmp"  # left by a save that was killed
    stale.write_bytes(b"half a checkpoint")
    trainer = Trainer.resume(tmp_path / "crashed")
    assert not stale.exists()
    assert trainer.trial == 20
    trainer.run(checkpoint_every=20)
    trainer.close()
    for a, b in zip(
        _arrays(reference / CHECKPOINT_FILE),
        _arrays(tmp_path / "crashed" / CHECKPOINT_FILE),
        strict=True,
    ):
        np.testing.assert_array_equal(a, b)
    expected = (reference / METRICS_FILE).read_text()
    assert (tmp_path / "crashed" / METRICS_FILE).read_text() == expected


def test_metrics_rows_hold_errors_per_move_in_mm_percent_and_pixels(uninterrupted):
    rows = [json.loads(r) for r in (uninterrupted / METRICS_FILE).read_text().splitlines()]
    assert [r["trial"] for r in rows] == [0, 20, 40, 60]
    for r in rows:
        moves = SMALL.fine_moves + 1
        assert len(r["mean_mm"]) == len(r["mean_percent_reach"]) == len(r["mean_px"]) == moves
        # % of reach is mm over the RIACS reach (1.0 m) — an independent unit conversion.
        np.testing.assert_allclose(
            np.array(r["mean_percent_reach"]), np.array(r["mean_mm"]) / 1000.0 * 100, rtol=1e-3
        )
    assert rows[-1]["mean_mm"][0] < rows[0]["mean_mm"][0]  # learning helped the coarse move


def test_same_seed_same_map_and_different_seed_different_map(uninterrupted, tmp_path):
    _train(SMALL, tmp_path / "same", checkpoint_every=1000)
    _train(replace(SMALL, seed=4), tmp_path / "other", checkpoint_every=1000)
    same = _arrays(tmp_path / "same" / CHECKPOINT_FILE)
    np.testing.assert_array_equal(same[0], _arrays(uninterrupted / CHECKPOINT_FILE)[0])
    assert not np.array_equal(_arrays(tmp_path / "other" / CHECKPOINT_FILE)[0], same[0])


def test_resume_without_checkpoint_or_with_lost_metrics_is_a_clear_error(uninterrupted, tmp_path):
    with pytest.raises(CheckpointError, match="no checkpoint"):
        Trainer.resume(tmp_path)
    (tmp_path / CHECKPOINT_FILE).write_bytes((uninterrupted / CHECKPOINT_FILE).read_bytes())
    (tmp_path / METRICS_FILE).write_text(
        "".join((uninterrupted / METRICS_FILE).open().readlines()[:2])
    )
    with pytest.raises(CheckpointError, match="2 readable rows, the checkpoint counts 4"):
        Trainer.resume(tmp_path)


def test_a_used_folder_is_refused_unless_forced_and_a_held_one_always(uninterrupted, tmp_path):
    before = (uninterrupted / METRICS_FILE).read_bytes()
    with pytest.raises(RunFolderError, match=r"already holds a run.*--force"):
        Trainer(SMALL, uninterrupted)
    assert (uninterrupted / METRICS_FILE).read_bytes() == before
    holder = Trainer(SMALL, tmp_path)
    try:
        with pytest.raises(RunFolderError, match=f"in use by process {os.getpid()}"):
            Trainer.resume(tmp_path)
    finally:
        holder.close()
    Trainer(SMALL, tmp_path, force=True).close()  # released: usable again, and forced


def test_the_map_learns_without_the_exact_model(monkeypatch, tmp_path):
    """What a robot knows: joint ranges, the ``ready`` keyframe, images. Kinematics, IK and the
    camera model raise if touched, and training (with rendered cameras) still runs."""
    forbid_the_exact_model(monkeypatch)
    monkeypatch.setattr(training, "INIT_TARGETS", 20)  # fewer renders: a quicker test
    config = RunConfig.of(env="PumaReach-v0", sensing="render", trials=12, lattice=(3, 2, 2),
                       eval_every=12, eval_trials=3, seed=1)  # fmt: skip
    trainer = Trainer(config, tmp_path)
    try:
        ready = np.array([-1.2963, -2.2265, -0.2073])  # the keyframe in puma560.xml
        np.testing.assert_array_equal(trainer.som.theta.reshape(-1, 3), np.tile(ready, (12, 1)))
        trainer.run()
    finally:
        trainer.close()
    assert trainer.som.t > 0  # trials were learned from


# -- the run state read as strictly as the map (issue 37) -----------------------------------------
#: A run that ends at trial 8 with held-out rows at trials 0, 4 and 8, resumed to 12.
TINY = RunConfig.of(trials=8, lattice=(3, 2, 2), eval_every=4, eval_trials=3)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiny")
    _train(TINY, out)
    return out


def _files(out):
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if p.is_file()}


def _rewritten(tiny_run, tmp_path, run_change=None, sim_change=None):
    """A copy of the tiny run whose checkpoint has ``run_change(run)`` and
    ``sim_change(state, model)`` applied to its run entries and simulation state (valid CRCs)."""
    out = tmp_path / "run"
    shutil.copytree(tiny_run, out)
    path = out / CHECKPOINT_FILE
    run, sim_state = read_unit(path)
    if run_change is not None:
        run_change(run)
    if sim_change is not None:
        env = TINY.make_env()
        sim_state = sim_change(sim_state.copy(), env.unwrapped.model)
        env.close()
    write_unit(path, load_map(path), run, sim_state)
    return out


def _refused(out, *words):
    """Trainer.resume(out) raises one-line CheckpointError naming ``words``; nothing changed."""
    before = _files(out)
    with pytest.raises(CheckpointError) as refused:
        Trainer.resume(out, trials=12)
    message = str(refused.value)
    assert "\n" not in message and all(w in message for w in words), message
    assert _files(out) == before


def _set(key, value):
    return lambda run: run.__setitem__(key, value)


@pytest.mark.parametrize("value", [-1, 0, 2, 1.0, True, "3", None])
def test_a_metrics_count_the_schedule_cannot_give_is_refused_before_the_log_is_cut(
    tiny_run, tmp_path, value
):
    """metrics_rows = -1 used to cut metrics.jsonl to its first rows; the schedule (trials 0, 4
    and 8) needs 3 rows."""
    _refused(_rewritten(tiny_run, tmp_path, _set("metrics_rows", value)), "metrics_rows")


@pytest.mark.parametrize("value", [-5, True, 7.5, "8", 9, 2**200, 7])
def test_a_damaged_trial_is_refused(tiny_run, tmp_path, value):
    """Negative, bool, fractional, text, beyond the run's 8 trials, and 7: below the map's 8
    learned trials (t)."""
    _refused(_rewritten(tiny_run, tmp_path, _set("trial", value)), "trial")


@pytest.mark.parametrize(
    "value",
    [{"coarse_mm": 1.0}, {"coarse_mm": "1", "fine_mm": 1.0}, [1.0, 2.0], None,
     {"coarse_mm": -1.0, "fine_mm": 1.0}, {"coarse_mm": 1e300, "fine_mm": 1.0}],
)  # fmt: skip
def test_damaged_running_errors_are_refused(tiny_run, tmp_path, value):
    _refused(_rewritten(tiny_run, tmp_path, _set("running", value)), "running")


@pytest.mark.parametrize("value", ["no", 1, None])
def test_a_pending_evaluation_that_is_not_a_flag_is_refused(tiny_run, tmp_path, value):
    _refused(_rewritten(tiny_run, tmp_path, _set("pending_eval", value)), "pending_eval")


def test_a_pending_evaluation_whose_row_is_logged_is_refused(tiny_run, tmp_path):
    """pending_eval true at trial 8 while the checkpoint counts the row of trial 8."""
    _refused(_rewritten(tiny_run, tmp_path, _set("pending_eval", True)), "metrics_rows")


def _rng_change(change):
    def edit(run):
        change(run["env_rng"])

    return edit


@pytest.mark.parametrize(
    "change",
    [lambda g: g["state"].__setitem__("state", 2**200),  # was OverflowError
     lambda g: g["state"].pop("inc"),  # was KeyError
     lambda g: g.pop("has_uint32"),
     lambda g: g.__setitem__("bit_generator", "MT19937"),
     lambda g: g.__setitem__("uinteger", -1)],
)  # fmt: skip
def test_a_damaged_env_generator_state_is_a_checkpoint_error_naming_it(tiny_run, tmp_path, change):
    _refused(_rewritten(tiny_run, tmp_path, _rng_change(change)), "env_rng")


def test_a_missing_env_generator_state_is_named(tiny_run, tmp_path):
    _refused(_rewritten(tiny_run, tmp_path, lambda run: run.pop("env_rng")), "lacks env_rng")


def _qpos_far(state, model):
    state[1] += 1e6  # rad: the first joint (state[0] is the time)
    return state


def _qvel_huge(state, model):
    state[1 + model.nq] = 1e300
    return state


def _time_huge(state, model):
    state[0] = 1e300  # s: a servo move's elapsed time would stay 0 (time + dt == time)
    return state


def _mocap_far(state, model):
    from envs.harness.checkpoint import sim_state_parts

    state[sim_state_parts(model)["mocap_pos"].start] = 1e6  # m
    return state


def _ctrl_beyond(state, model):
    from envs.harness.checkpoint import sim_state_parts

    state[sim_state_parts(model)["ctrl"].start] = 100.0
    return state


@pytest.mark.parametrize(
    ("change", "words"),
    [(_qpos_far, ("qpos", "joint1")), (_qvel_huge, ("qvel", "rad/s")),
     (_ctrl_beyond, ("ctrl",)), (_time_huge, ("time",)), (_mocap_far, ("mocap_pos",)),
     (lambda s, m: s[:-1], ("simulation state",)),
     (lambda s, m: s.astype(np.float32), ("float32",))],
)  # fmt: skip
def test_a_simulation_state_this_model_cannot_have_is_refused(tiny_run, tmp_path, change, words):
    """Only finiteness was checked: joints 1e6 rad outside their range and speeds of 1e300
    rad/s were restored."""
    _refused(_rewritten(tiny_run, tmp_path, sim_change=change), *words)


def test_the_simulators_own_limit_overshoot_is_within_the_tolerance():
    """Servo trials with the arm kept (the largest overshoots): every physics step's joints lie
    within their ranges widened by JOINT_RANGE_TOLERANCE, and the state after each trial
    passes check_sim_state."""
    from envs.harness.checkpoint import JOINT_RANGE_TOLERANCE, check_sim_state, get_sim_state

    for env_id in ("RiacsReach-v0", "PumaReach-v0"):
        config = RunConfig.of(env=env_id, control="servo", lattice=(3, 2, 2), keep_arm=True)
        env = config.make_env()
        base = env.unwrapped
        som = training.initial_map(config, env)
        limited = base.model.jnt_limited.astype(bool)
        adr, (low, high) = base.model.jnt_qposadr[limited], base.model.jnt_range[limited].T
        worst = []

        def on_step(_, base=base, adr=adr, low=low, high=high, worst=worst):
            q = base.data.qpos[adr]
            worst.append(float(np.max(np.maximum(low - q, q - high))))

        base.on_physics_step = on_step
        for _ in range(30):
            learn_from(som, run_trial(env, som, fine_moves=1, keep_arm=True, explore=True))
            check_sim_state(base.model, get_sim_state(env))
        env.close()
        assert 0 < max(worst) < JOINT_RANGE_TOLERANCE, (env_id, max(worst))


def test_resume_keeps_the_runs_checkpoint_interval_unless_given_a_new_one(tmp_path):
    config = replace(TINY, trials=12)
    trainer = Trainer(config, tmp_path, checkpoint_every=3)
    trainer.close()
    saved_at = []
    trainer = Trainer.resume(tmp_path)
    original = trainer.save
    trainer.save = lambda: (saved_at.append(trainer.trial), original())[1]
    with pytest.raises(StopRequested):

        def stop(trial, running):
            if trial == 7:
                os.kill(os.getpid(), signal.SIGINT)

        trainer.run(progress=stop)  # no interval given: the run's 3
    trainer.close()
    assert saved_at == [0, 3, 6, 7], saved_at  # every 3 trials (the evaluation at 0), the stop
    assert read_unit(tmp_path / CHECKPOINT_FILE)[0]["checkpoint_every"] == 3
    trainer = Trainer.resume(tmp_path, checkpoint_every=5)
    trainer.close()
    trainer = Trainer.resume(tmp_path)  # nothing saved by the last: still 3
    assert trainer.checkpoint_every == 3
    trainer.run(checkpoint_every=5)
    trainer.close()
    assert read_unit(tmp_path / CHECKPOINT_FILE)[0]["checkpoint_every"] == 5


def test_a_checkpoint_of_the_previous_layout_resumes_with_the_default_interval(tiny_run, tmp_path):
    """The run entries the previous release wrote (no checkpoint_every): the run resumes with
    the interval train.py always defaulted to and ends as the same run in the new layout."""
    keys = {"config", "identity", "trial", "running", "metrics_rows", "pending_eval", "env_rng"}
    old = _rewritten(tiny_run, tmp_path, lambda run: [run.pop(k) for k in set(run) - keys])
    assert set(read_unit(old / CHECKPOINT_FILE)[0]) == keys
    new = tmp_path / "new"
    shutil.copytree(tiny_run, new)
    for out in (old, new):
        trainer = Trainer.resume(out, trials=12)
        assert trainer.checkpoint_every == CHECKPOINT_EVERY == 1000
        trainer.run()
        trainer.close()
    for a, b in zip(_arrays(old / CHECKPOINT_FILE), _arrays(new / CHECKPOINT_FILE), strict=True):
        np.testing.assert_array_equal(a, b)
    assert (old / METRICS_FILE).read_bytes() == (new / METRICS_FILE).read_bytes()
