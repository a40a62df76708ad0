"""Training runs: checkpoints, a stop signal and --resume give the arrays of an uninterrupted run,
bit for bit; held-out metrics are logged as documented; a trained map beats the initial one."""

from __future__ import annotations

import json
import os
import signal
from dataclasses import replace

import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.harness import training
from envs.harness.checkpoint import CHECKPOINT_FILE, OLD_CHECKPOINT_FILE, read_unit
from envs.harness.run_folder import RunFolderError
from envs.harness.stopping import StopRequested
from envs.harness.training import METRICS_FILE, RunConfig, Trainer
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
