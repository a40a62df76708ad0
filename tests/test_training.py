"""Training runs: checkpoints, Ctrl-C and --resume give the arrays of an uninterrupted run, bit
for bit; held-out metrics are logged as documented; a trained map beats the initial one."""

from __future__ import annotations

import json

import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.training import MAP_FILE, METRICS_FILE, STATE_FILE, RunConfig, Trainer
from learners.persistence import CheckpointError
from learners.som import VisuomotorSOM

SMALL = RunConfig(trials=60, lattice=(4, 3, 2), eval_every=20, eval_trials=10, seed=3)


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


def test_resume_after_ctrl_c_is_bit_identical(uninterrupted, tmp_path):
    def interrupt(trial, running):
        if trial == 27:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        _train(SMALL, tmp_path, checkpoint_every=1000, progress=interrupt)
    assert json.loads((tmp_path / STATE_FILE).read_text())["trial"] == 27
    trainer = Trainer.resume(tmp_path)
    trainer.run(checkpoint_every=1000)
    trainer.close()
    for a, b in zip(_arrays(uninterrupted / MAP_FILE), _arrays(tmp_path / MAP_FILE), strict=True):
        np.testing.assert_array_equal(a, b)
    assert (tmp_path / METRICS_FILE).read_text() == (uninterrupted / METRICS_FILE).read_text()


def test_resume_after_a_crash_redoes_from_the_last_periodic_checkpoint(tmp_path):
    """A crash (not Ctrl-C) leaves the checkpoint of trial 20 and metrics up to trial 30; the
    resumed run drops the row of trial 30 and ends as an unbroken run does."""
    config = RunConfig(**{**SMALL.__dict__, "trials": 40, "eval_every": 10})
    reference = _train(config, tmp_path / "reference", checkpoint_every=20).out

    def crash(trial, running):
        if trial == 35:
            raise RuntimeError("power cut")

    with pytest.raises(RuntimeError):
        _train(config, tmp_path / "crashed", checkpoint_every=20, progress=crash)
    trainer = Trainer.resume(tmp_path / "crashed")
    assert trainer.trial == 20
    trainer.run(checkpoint_every=20)
    trainer.close()
    for a, b in zip(
        _arrays(reference / MAP_FILE), _arrays(tmp_path / "crashed" / MAP_FILE), strict=True
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
    _train(RunConfig(**{**SMALL.__dict__, "seed": 4}), tmp_path / "other", checkpoint_every=1000)
    same = _arrays(tmp_path / "same" / MAP_FILE)
    np.testing.assert_array_equal(same[0], _arrays(uninterrupted / MAP_FILE)[0])
    assert not np.array_equal(_arrays(tmp_path / "other" / MAP_FILE)[0], same[0])


def test_resume_without_checkpoint_or_with_mismatched_files_is_a_clear_error(
    uninterrupted, tmp_path
):
    with pytest.raises(CheckpointError, match="no checkpoint"):
        Trainer.resume(tmp_path)
    # trainer.json from one moment, som.npz from another: refused, not silently mixed.
    state = json.loads((uninterrupted / STATE_FILE).read_text())
    state["learn_calls"] += 1
    (tmp_path / STATE_FILE).write_text(json.dumps(state))
    (tmp_path / MAP_FILE).write_bytes((uninterrupted / MAP_FILE).read_bytes())
    with pytest.raises(CheckpointError, match="different moments"):
        Trainer.resume(tmp_path)
