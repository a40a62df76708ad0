"""The continual mode of the Kohonen map (learners.som.schedules.Continual): when it re-adapts, what
its schedules are then, that it changes nothing while the error holds, and that it is saved."""

from __future__ import annotations

import math

import numpy as np
import pytest

from learners.som.controller import DEFAULT_EPS, DEFAULT_EPS_OUT, VisuomotorSOM
from learners.som.schedules import Continual, ErrorMonitor, Schedule
from models import riacs

from helpers import riacs_pixels

T_MAX = 100
CAMERAS_MOVED = 60.0  # px, both images


pixels = riacs_pixels


def trial(som: VisuomotorSOM, target: np.ndarray, shift: float = 0.0) -> None:
    u = pixels(target, shift)
    som.reset()
    theta0 = som.act(u)
    v0 = pixels(theta0, shift)
    theta1 = som.act(u, v0, explore=True)
    som.learn(u, theta0, v0, theta1, pixels(theta1, shift))


def targets(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(riacs.LOWER + 0.1, riacs.UPPER - 0.1, (n, 3))


def new_map(continual: Continual | None) -> VisuomotorSOM:
    return VisuomotorSOM(
        riacs.LOWER, riacs.UPPER, t_max=T_MAX, rng=3, input_high=[320] * 4, continual=continual
    )


def test_a_jump_in_the_error_triggers_when_the_running_means_part_by_the_ratio():
    p = Continual(fast=0.05, slow=0.005, trigger=2.0)
    monitor, old, new = ErrorMonitor(p), 1.0, 8.0
    for t in range(50):
        assert not monitor.observe(t, 10, old)
    # Closed form: after n trials at the new level each mean has moved (1 - (1 - w)^n) of the way.
    gap = math.log(new / old)
    n = np.arange(1, 200)
    parted = gap * ((1 - p.slow) ** n - (1 - p.fast) ** n) > math.log(p.trigger)
    expected = int(n[parted][0])
    fired = [monitor.observe(50 + k - 1, 10, new) for k in range(1, 200)]
    assert fired.index(True) + 1 == expected
    assert monitor.readaptations == 1


def test_no_trigger_before_t_max_or_while_the_error_holds():
    monitor = ErrorMonitor(Continual())
    assert not any(monitor.observe(t, 100, 1.0 + 0.1 * math.sin(t)) for t in range(400))
    assert not any(monitor.observe(t, 1000, 50.0) for t in range(400, 600))  # t < t_max


def test_readaptation_runs_the_schedules_back_and_down_again():
    p = Continual(rewind=0.25, readapt=40)
    monitor = ErrorMonitor(p, {"fast": 0.0, "reference": 0.0, "start": 130})
    assert monitor.fraction(130, T_MAX) == 0.25
    assert monitor.fraction(150, T_MAX) == pytest.approx(0.25 + 0.75 * 20 / 40)
    assert monitor.fraction(170, T_MAX) == 1.0
    eps = DEFAULT_EPS.initial * (DEFAULT_EPS.final / DEFAULT_EPS.initial) ** 0.25
    assert Schedule.of((DEFAULT_EPS.initial, DEFAULT_EPS.final)).at(0.25) == pytest.approx(eps)


def test_the_map_rewinds_its_rates_when_the_cameras_change():
    som = new_map(Continual(fast=0.2, slow=0.01, trigger=1.5, rewind=0.3, readapt=50))
    for target in targets(T_MAX + 50, 1):
        trial(som, target)
    assert som.monitor.readaptations == 0
    assert som.params()[2] == pytest.approx(DEFAULT_EPS_OUT.final)
    for target in targets(60, 2):
        trial(som, target, CAMERAS_MOVED)
        if som.monitor.readaptations:
            break
    assert som.monitor.readaptations == 1
    eps_out = DEFAULT_EPS_OUT.initial * (DEFAULT_EPS_OUT.final / DEFAULT_EPS_OUT.initial) ** 0.3
    assert som.params()[2] == pytest.approx(eps_out, rel=0.05)


def test_without_a_change_continual_equals_the_standard_schedules():
    standard, continual = new_map(None), new_map(Continual())
    for target in targets(T_MAX + 100, 4):
        trial(standard, target)
        trial(continual, target)
    assert continual.monitor.readaptations == 0
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(standard, name), getattr(continual, name))


def test_the_continual_state_is_saved_and_continues_bit_identically(tmp_path):
    som = new_map(Continual(fast=0.2, slow=0.01, trigger=1.5, rewind=0.3, readapt=50))
    for target in targets(T_MAX + 20, 5):
        trial(som, target)
    for target in targets(10, 6):
        trial(som, target, CAMERAS_MOVED)
    som.save(tmp_path / "checkpoint.npz")
    back = VisuomotorSOM.load(tmp_path / "checkpoint.npz")
    assert back.monitor.params == som.monitor.params
    assert back.monitor.state() == som.monitor.state()
    for target in targets(30, 7):
        trial(som, target, CAMERAS_MOVED)
        trial(back, target, CAMERAS_MOVED)
    np.testing.assert_array_equal(back.theta, som.theta)
    assert back.monitor.state() == som.monitor.state()


def test_bad_continual_options_are_refused():
    with pytest.raises(ValueError, match="trigger"):
        Continual(trigger=0.5)
    with pytest.raises(ValueError, match="readapt"):
        Continual(readapt=0)
