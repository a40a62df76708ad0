"""The compiled learning kernel is the compiled form of the numpy update rule: on random maps and
trials, ``kernels.learn`` and ``update_rule.targets`` + ``mrs_update`` give the same w, |w|², θ
and A, for both θ targets and with the sensing-noise term; and the numpy rule is the formula
written out by hand with a Python loop over the neurons."""

from __future__ import annotations

import math

import numpy as np
import pytest

from learners.som import kernels
from learners.som.config import NOISE_TERMS
from learners.som.lattice import Lattice
from learners.som.state import MapState
from learners.som.update_rule import brause_update, mrs_update, targets

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")

LATTICE = (5, 4, 3)
J, D = 3, 4
LOWER, UPPER = np.zeros(J), np.full(J, 2.0)


def random_map(rng: np.random.Generator) -> MapState:
    N = math.prod(LATTICE)
    shape = np.array(LATTICE, dtype=np.int64)
    return MapState(
        rng.uniform(0, 1, (N, D)), rng.uniform(0.2, 1.8, (N, J)), rng.normal(0, 0.5, (N, J, D)),
        shape, np.zeros((0, 1)), np.zeros(0),
    )  # fmt: skip


def random_trial(rng: np.random.Generator):
    u, v0, v1 = rng.uniform(0, 1, (3, D))
    return u, rng.uniform(0.2, 1.8, J), v0, rng.uniform(0.2, 1.8, J), v1


@pytest.mark.parametrize("noise", [0.0, 0.05])
@pytest.mark.parametrize("kind", ["coarse-error", "fine-error"])
def test_the_kernel_equals_the_numpy_rule_on_random_maps(kind, noise):
    rng = np.random.default_rng(11)
    grid = Lattice(LATTICE)
    box = np.stack((np.full(D, 0.5), np.full(D, 1 / 10.5)))
    joints = np.stack((LOWER, UPPER, (LOWER + UPPER) / 2, 1 / ((UPPER - LOWER) * 10.5)))
    for _ in range(50):
        numpy_map = random_map(rng)
        compiled = numpy_map.copy()
        trial = random_trial(rng)
        eps, sigma, eps_out, sigma_out = rng.uniform(0.05, 0.9), *rng.uniform(0.3, 2.5, 1), \
            rng.uniform(0.05, 0.9), *rng.uniform(0.3, 2.5, 1)  # fmt: skip
        u, v0, v1 = trial[0], trial[2], trial[4]
        s = int(((numpy_map.w - u) ** 2).sum(1).argmin())
        dv = v1 - v0
        noise_term = NOISE_TERMS * noise**2
        theta_star, a_star = targets(kind, numpy_map, s, trial, dv / (dv @ dv), noise_term)
        mrs_update(numpy_map, grid, s, u, theta_star, a_star, (eps, sigma, eps_out, sigma_out),
                   LOWER, UPPER)  # fmt: skip
        found = kernels.learn(
            s, kind == "coarse-error", *trial, 0.0, noise_term, compiled.w, compiled.w2,
            compiled.theta, compiled.A, box, joints, eps, grid.weights(sigma), eps_out,
            grid.weights(sigma_out), compiled.shape, compiled.block_centre,
            compiled.block_radius,
        )  # fmt: skip
        assert found == kernels.LEARNED
        np.testing.assert_array_equal(compiled.w, numpy_map.w)  # the same operations
        np.testing.assert_allclose(compiled.w2, numpy_map.w2, rtol=1e-14)
        np.testing.assert_allclose(compiled.theta, numpy_map.theta, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(compiled.A, numpy_map.A, rtol=1e-12, atol=1e-14)


def by_hand(state: MapState, s, trial, kind, noise, rates, lattice_shape):
    """The update written out neuron by neuron from the formulas of docs/map.md."""
    u, th0, v0, th1, v1 = trial
    w, th, A = state.w.copy(), state.theta.copy(), state.A.copy()
    dv = v1 - v0
    a_star = A[s] + (np.outer(th1 - th0 - A[s] @ dv, dv) + NOISE_TERMS * noise**2 * A[s]) / (
        dv @ dv
    )
    theta_star = th[s] + A[s] @ (u - v0) if kind == "coarse-error" else th1 + A[s] @ (w[s] - v1)
    eps, sigma, eps_out, sigma_out = rates
    coords = np.array(np.unravel_index(np.arange(len(w)), lattice_shape)).T
    for r in range(len(w)):
        d2 = float(((coords[r] - coords[s]) ** 2).sum())
        h, h_out = math.exp(-d2 / (2 * sigma**2)), math.exp(-d2 / (2 * sigma_out**2))
        w[r] += eps * h * (u - w[r])
        th[r] = np.clip(th[r] + eps_out * h_out * (theta_star - th[r]), LOWER, UPPER)
        A[r] += eps_out * h_out * (a_star - A[r])
    return w, th, A


@pytest.mark.parametrize("noise", [0.0, 0.05])
@pytest.mark.parametrize("kind", ["coarse-error", "fine-error"])
def test_the_numpy_rule_is_the_formula(kind, noise):
    rng = np.random.default_rng(5)
    grid = Lattice(LATTICE)
    state = random_map(rng)
    trial = random_trial(rng)
    rates = (0.6, 3.0, 0.4, 2.5)  # wide: the Gaussians' cut-off reaches every neuron here
    s = 17
    w, th, A = by_hand(state, s, trial, kind, noise, rates, LATTICE)
    dv = trial[4] - trial[2]
    theta_star, a_star = targets(kind, state, s, trial, dv / (dv @ dv), NOISE_TERMS * noise**2)
    mrs_update(state, grid, s, trial[0], theta_star, a_star, rates, LOWER, UPPER)
    assert grid.cutoff_radius2(2.5) >= sum((n - 1) ** 2 for n in LATTICE)
    np.testing.assert_allclose(state.w, w, rtol=1e-13)
    np.testing.assert_allclose(state.theta, th, rtol=1e-13)
    np.testing.assert_allclose(state.A, A, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(state.w2, (state.w**2).sum(1), rtol=1e-13)


def test_brause_update_moves_the_step_neighbourhood_by_gamma_alone():
    rng = np.random.default_rng(2)
    grid = Lattice(LATTICE)
    state = random_map(rng)
    before = state.copy()
    trial = random_trial(rng)
    s, gamma, radius = 22, 0.3, 1.5
    theta_star, a_star = rng.uniform(0.2, 1.8, J), rng.normal(0, 1, (J, D))
    brause_update(state, grid, s, trial[0], theta_star, a_star, gamma, radius, LOWER, UPPER)
    coords = np.array(np.unravel_index(np.arange(len(state.w)), LATTICE)).T
    inside = ((coords - coords[s]) ** 2).sum(1) <= radius**2
    for r in range(len(state.w)):
        g = gamma if inside[r] else 0.0
        np.testing.assert_allclose(state.w[r], before.w[r] + g * (trial[0] - before.w[r]), 1e-14)
        expected = np.clip(before.theta[r] + g * (theta_star - before.theta[r]), LOWER, UPPER)
        np.testing.assert_allclose(state.theta[r], expected, rtol=1e-14)
        np.testing.assert_allclose(state.A[r], before.A[r] + g * (a_star - before.A[r]), 1e-14)
    np.testing.assert_allclose(state.w2, (state.w**2).sum(1), rtol=1e-13)
