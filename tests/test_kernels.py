"""The compiled hot path (numba) against the numpy reference over 1,000 trials, and its guards.

Tolerance: the kernels make the same elementwise updates in the same order, so w (and with it
every winner) must match bit for bit. The output averaging sums over up to N neurons in another
order than numpy's dot products; each sum then differs by at most ~K ulp of its largest term
(K ≤ 336 terms of |θ| < 4 rad: ~3e-13), and every later update is a convex combination
θ_r ← (1 − ε'h)θ_r + ε'h θ*, which does not grow a difference. 1e-12 rad bounds that with room;
the measured difference over 1,000 trials is ~1e-15.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from learners.guards import INPUT_MARGIN, InputBox
from learners.som.controller import VisuomotorSOM, kernels
from learners.som.schedules import Continual
from models.riacs import LOWER, UPPER

pytestmark = pytest.mark.skipif(
    not kernels.available(), reason="numba not installed (pip install 'visuomotor[fast]')"
)
IMAGE = np.array([320.0, 240.0, 320.0, 240.0])  # px
TOLERANCE = 1e-12  # rad, and rad/px for A (see the module docstring)


def inputs(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    U = rng.uniform(0.0, IMAGE, size=(n, 4))
    return U, U + rng.normal(0.0, 5.0, U.shape), U + rng.normal(0.0, 1.0, U.shape)


def run(kernel: str, trials: int = 1000, **kw) -> tuple[VisuomotorSOM, np.ndarray]:
    """A map trained on ``trials`` trials (t_max = 2/3 of them, so both phases count), and
    every command it gave, (trials, 4, J): coarse, fine, second fine, and a fine move towards
    another target (Ā of its winner)."""
    som = VisuomotorSOM(
        LOWER, UPPER, t_max=2 * trials // 3, rng=3, input_high=IMAGE, kernel=kernel, **kw
    )
    commands = []
    for u, v0, v1 in zip(*inputs(trials), strict=True):
        som.reset()
        theta0 = som.act(u)
        theta1 = som.act(u, v0, explore=True)
        commands.append([theta0, theta1, som.act(u, v1), som.act(u + 1.0, v1)])  # new target
        som.learn(u, theta0, v0, theta1, v1)
    return som, np.array(commands)


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"theta_target": "fine-error"},
        {"averaging": "winner"},
        {"refine": False},
        {"abar": "average"},
        {"lattice": (17, 9)},
        {"lattice": (5, 4, 3)},
        {"protocol": "brause"},  # the compiled path steps aside: Brause's loop is numpy only
        {"continual": Continual()},  # ... and so it does for the continual mode's monitor
    ],
)
def test_compiled_path_equals_the_numpy_reference_over_1000_trials(options):
    fast, fast_commands = run("numba", **options)
    ref, ref_commands = run("numpy", **options)
    np.testing.assert_array_equal(fast.w, ref.w)  # the same winners all along
    np.testing.assert_allclose(fast.theta, ref.theta, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(fast.A, ref.A, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(fast_commands, ref_commands, rtol=0, atol=TOLERANCE)
    assert fast.t == ref.t and fast.skipped == ref.skipped
    U = inputs(200, seed=1)[0]
    np.testing.assert_allclose(fast.act_batch(U), ref.act_batch(U), rtol=0, atol=TOLERANCE)


def test_pruned_winner_search_of_large_lattices_equals_the_plain_scan():
    fast, _ = run("numba", trials=300, lattice=(16, 16, 16))  # 4096 neurons: pruned search
    ref, _ = run("numpy", trials=300, lattice=(16, 16, 16))
    assert fast.learned.pruned and not ref.learned.pruned
    np.testing.assert_array_equal(fast.w, ref.w)  # the same winners in all 300 trials
    np.testing.assert_allclose(fast.theta, ref.theta, rtol=0, atol=TOLERANCE)
    rng = np.random.default_rng(5)
    c = fast.coords / 15.0  # an ordered map, where most blocks are skipped
    fast.w = np.c_[c[:, :2], c[:, :2] * 0.9 + c[:, 2:] * 0.1] * IMAGE + rng.normal(0, 1, (4096, 4))
    for u, v0, v1 in zip(*inputs(300, seed=7), strict=True):  # moved neurons widen blocks
        fast.learn(u, fast.act(u), v0, fast.act(u, v0), v1)
    for u in rng.uniform(-0.2, 1.2, size=(2000, 4)) * IMAGE:  # also outside the image
        assert fast.winner(u) == int(np.argmin(((fast.w - u) ** 2).sum(1)))


@pytest.mark.parametrize("kernel", ["numba", "numpy"])
def test_bad_and_skipped_trials_are_handled_alike(kernel):
    som = VisuomotorSOM(LOWER, UPPER, t_max=10, rng=0, input_high=IMAGE, kernel=kernel)
    u, v0, v1 = (x[0] for x in inputs(1))
    theta = np.array([0.5, 0.5, 1.0])
    before = som.w.copy(), som.theta.copy(), som.A.copy()
    with pytest.raises(ValueError, match="theta1"):
        som.learn(u, theta, v0, [0.5, np.nan, 1.0], v1)
    assert som.learn(u, theta, v0, theta, [np.nan, 1.0, 2.0, 3.0]) is False
    assert som.learn(u, theta, v0, theta, v0 + 1e-5) is False
    assert som.skipped == {"not_visible": 1, "small_dv": 1} and som.t == 0
    for array, old in zip((som.w, som.theta, som.A), before, strict=True):
        np.testing.assert_array_equal(array, old)


def test_kernel_choice_is_checked():
    with pytest.raises(ValueError, match="auto, numba, numpy"):
        VisuomotorSOM(LOWER, UPPER, kernel="cuda")
    with pytest.raises(ValueError, match="at most 3 axes"):
        VisuomotorSOM(LOWER, UPPER, lattice=(2, 2, 2, 2), kernel="numba")
    assert VisuomotorSOM(LOWER, UPPER, lattice=(2, 2, 2, 2)).kernel == "numpy"
    assert VisuomotorSOM(LOWER, UPPER).kernel == "numba"


U0, V0 = np.array([100.0, 80.0, 120.0, 90.0]), np.array([104.0, 77.0, 125.0, 93.0])  # px
TH = np.array([0.5, 0.5, 1.0])  # rad
#: One wrong call each, made after a coarse and a fine act(U0) (and a reset for "fine first").
BAD = {
    "coarse u NaN": lambda m: m.act([np.nan, 1.0, 2.0, 3.0]),
    "coarse u far": lambda m: m.act([1e6, 1.0, 2.0, 3.0]),
    "coarse u shape": lambda m: m.act(U0[:3]),
    "fine v NaN": lambda m: m.act(U0, [1.0, np.inf, 2.0, 3.0], explore=True),
    "fine v far": lambda m: m.act(U0, [1.0, 2.0, -1e7, 3.0], explore=True),
    "fine u far": lambda m: m.act([1.0, 2.0, 3.0, 1e9], V0, explore=True),
    "fine v shape": lambda m: m.act(U0, V0[:2], explore=True),
    "fine first": lambda m: m.act(U0, V0, explore=True),
    "learn u NaN": lambda m: m.learn([np.nan, 1.0, 2.0, 3.0], TH, V0, TH, U0),
    "learn theta1 far": lambda m: m.learn(U0, TH, V0, [0.5, 200.0, 1.0], U0),
    "learn v0 far, theta0 NaN": lambda m: m.learn(U0, [np.nan, 0, 0], [0, 0, 0, 1e8], TH, U0),
    "learn v1 shape": lambda m: m.learn(U0, TH, V0, TH, U0[:3]),
}


def _snapshot(som: VisuomotorSOM) -> list:
    config, arrays = som.state()  # w, θ, A, fine-move memory, t, skip counts, generator state
    return [json.dumps(config, sort_keys=True), {k: a.tolist() for k, a in arrays.items()}]


@pytest.mark.parametrize("call", BAD.values(), ids=BAD.keys())
def test_bad_input_is_refused_alike_by_both_paths_before_anything_changes(call):
    """The compiled path checks inside its kernels; the error (type and message) must be the
    reference path's, and nothing may change: arrays, memory, counters, the generator."""
    errors = []
    for kernel in ("numba", "numpy"):
        som = VisuomotorSOM(LOWER, UPPER, t_max=50, rng=1, input_high=IMAGE, kernel=kernel)
        for u, v0, v1 in zip(*inputs(20), strict=True):
            som.reset()
            theta0, theta1 = som.act(u), som.act(u, v0, explore=True)
            som.learn(u, theta0, v0, theta1, v1)
        som.act(U0)
        som.act(U0, V0, explore=True)  # memory of a fine move, for the refine step
        if call is BAD["fine first"]:
            som.reset()
        before = _snapshot(som)
        with pytest.raises(ValueError) as error:
            call(som)
        assert _snapshot(som) == before
        errors.append(str(error.value))
    assert errors[0] == errors[1]


def test_the_kernels_box_test_is_the_guards():
    """kernels.status against guards.InputBox on points spread around the margin's edges."""
    box = InputBox(np.zeros(4), IMAGE, "input box")
    packed = np.stack((box.centre, box.inv_half))
    rng = np.random.default_rng(2)
    edge = box.centre + (box.high - box.low) * (INPUT_MARGIN + 0.5)  # the outermost accepted
    points = edge * (1.0 + rng.normal(0.0, 1e-15, size=(2000, 4)) * rng.integers(0, 2, (2000, 4)))
    points = np.r_[points, rng.uniform(-20.0, 20.0, size=(2000, 4)) * IMAGE]
    for x in points:
        assert (kernels.status(x, packed) == kernels.OK) == box.inside(x)
        assert kernels.status(np.r_[x[:3], np.nan], packed) == kernels.NOT_FINITE
