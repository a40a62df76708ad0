"""Honest held-out figures: a trial stopped by an unseen marker counts where it stopped."""

import numpy as np
import pytest

from envs.harness.evaluation import Evaluation, carried_forward, evaluate
from envs.harness.trials import Trial
from learners.base import Controller

from helpers import assert_drawn_png


def test_a_trial_stopped_after_the_coarse_move_keeps_its_coarse_distance():
    trial = Trial(target_px=np.zeros(4), start_distance=0.5, start_pixel_error=40.0,
                  start_pos=np.ones(3))  # fmt: skip
    trial.distances, trial.pixel_errors = [0.02], [3.0]
    trial.reached = [np.array([0.1, 0.2, 0.3])]
    distances, pixels, ended = carried_forward(trial, moves=4)
    np.testing.assert_array_equal(distances, [0.02, 0.02, 0.02, 0.02])
    np.testing.assert_array_equal(pixels, [3.0, 3.0, 3.0, 3.0])
    np.testing.assert_array_equal(ended, [0.1, 0.2, 0.3])


def test_a_trial_whose_target_was_not_seen_keeps_its_start_distance():
    trial = Trial(target_px=np.full(4, np.nan), start_distance=0.5, start_pixel_error=40.0,
                  start_pos=np.ones(3))  # fmt: skip
    distances, _, ended = carried_forward(trial, moves=3)
    np.testing.assert_array_equal(distances, [0.5, 0.5, 0.5])
    np.testing.assert_array_equal(ended, np.ones(3))


class _ScriptedEnv:
    """Trial i: the arm starts 1 m away; move k lands at DISTANCES[i][k]; the marker is lost
    after move STOP[i] (None: never)."""

    DISTANCES = ((0.04, 0.01, 0.002), (0.03, 0.02, 0.001), (0.05, 0.004, 0.003), (0.06, 0.3, 0.2))
    STOP = (None, 0, 1, None)
    reach = 2.0

    def __init__(self) -> None:
        self.i, self.k = -1, 0
        self.unwrapped = self

    def reset(self, options=None):
        self.i, self.k = self.i + 1, 0
        return None, self._info(1.0)

    def step(self, command):
        d = self.DISTANCES[self.i][self.k]
        self.seen = self.STOP[self.i] is None or self.k < self.STOP[self.i]
        self.k += 1
        return None, -d, False, False, self._info(d)

    def _info(self, d):
        return {"distance": d, "pixel_error": 100 * d, "visible": True,
                "target_pos": np.zeros(3), "effector_pos": np.full(3, d)}  # fmt: skip

    def sensed_target(self):
        return np.zeros(4)

    def sensed_effector(self):
        return np.zeros(4) if self.seen else np.full(4, np.nan)


class _Still(Controller):
    def act(self, u, v=None):
        return np.zeros(3)


def test_evaluate_counts_every_trial_where_it_stopped():
    result = evaluate(_ScriptedEnv(), _Still(), trials=4, fine_moves=2)
    expected = np.array(
        [[0.04, 0.01, 0.002], [0.03, 0.03, 0.03], [0.05, 0.004, 0.004], [0.06, 0.3, 0.2]]
    )
    np.testing.assert_array_equal(result.distances, expected)
    np.testing.assert_array_equal(result.moves_made, [3, 1, 2, 3])
    s = result.summary()
    assert s["complete_trials"] == 2 and s["complete_fraction"] == 0.5
    assert s["made_fraction"] == [1.0, 0.75, 0.5]
    np.testing.assert_allclose(s["mean_mm"], [45.0, 86.0, 59.0])  # by hand, all four trials
    np.testing.assert_allclose(s["median_mm"], [45.0, 20.0, 17.0])
    np.testing.assert_allclose(s["mean_percent_reach"], np.array([45.0, 86.0, 59.0]) / 20)
    np.testing.assert_allclose(s["mean_px"], [4.5, 8.6, 5.9])
    # 95th percentile by linear interpolation between the two largest of four: 0.85 of the way.
    np.testing.assert_allclose(s["p95_mm"][2], 30 + 0.85 * (200 - 30))


def test_an_evaluation_built_without_moves_made_counts_every_trial_complete():
    e = Evaluation(np.ones((2, 3)), np.ones((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)), 1.0, 0.0)
    assert e.summary()["complete_trials"] == 2


@pytest.mark.parametrize("name", ["error_map", "error_histogram", "error_vectors"])
def test_plots_are_written_where_asked(tmp_path, name):
    """The files; what they show (every trial, stopped ones included) is in test_figures.py."""
    from envs.harness import plots

    result = evaluate(_ScriptedEnv(), _Still(), trials=4, fine_moves=2)
    path = getattr(plots, name)(result, tmp_path / "new folder" / f"{name}.png", subject="arm")
    assert path == tmp_path / "new folder" / f"{name}.png"
    assert_drawn_png(path)
