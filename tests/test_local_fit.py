"""The fine moves' local fit of Ā (``learners/som/local_fit.py``) against a smooth map with a known
Jacobian, a field it must recover, and the two paths (numba, numpy) against each other."""

from __future__ import annotations

import numpy as np
import pytest

from learners.som.controller import VisuomotorSOM, kernels
from learners.som.lattice import Lattice
from learners.som.local_fit import local_abar
from models.riacs import LOWER, UPPER

SPAN = 0.6  # rad: the neurons' joint angles form a grid over [−SPAN, SPAN]³


def pixels(theta: np.ndarray) -> np.ndarray:
    """A smooth, curved map of 3 joints (..., 3) to 4 inputs (..., 4)."""
    a, b, c = np.moveaxis(theta, -1, 0)
    return np.stack(
        (np.sin(a) + 0.3 * b * b, np.cos(b) + c, a * c + b, np.exp(0.3 * a) + c * c), -1
    )


def jacobian(theta: np.ndarray) -> np.ndarray:
    """∂pixels/∂θ (4, 3), by hand."""
    a, b, c = theta
    return np.array(
        [
            [np.cos(a), 0.6 * b, 0.0],
            [0.0, -np.sin(b), 1.0],
            [c, 1.0, a],
            [0.3 * np.exp(0.3 * a), 0.0, 2.0 * c],
        ]
    )


def known_map(abar: str, side: int) -> VisuomotorSOM:
    """A map that holds the exact values at its neurons: θ_r on a side³ grid, w_r =
    pixels(θ_r), A_r = pinv(J(θ_r)); σ' at its floor, so the averaged Ā is the winner's A_s."""
    grid = np.linspace(-SPAN, SPAN, side)
    theta = np.stack(np.meshgrid(grid, grid, grid, indexing="ij"), -1).reshape(-1, 3)
    w = pixels(theta)
    som = VisuomotorSOM(
        -np.ones(3) * 2, np.ones(3) * 2, lattice=(side,) * 3, input_dim=4, rng=0, abar=abar,
        input_low=w.min(0) - 1, input_high=w.max(0) + 1, t_max=10,
    )  # fmt: skip
    som.w, som.theta = w, theta
    som.A = np.array([np.linalg.pinv(jacobian(t)) for t in theta])
    som.t = som.t_max
    return som


def measured_abar(som: VisuomotorSOM, u: np.ndarray, step: float = 1e-3) -> np.ndarray:
    """Ā (3, 4) read through the public moves: a first fine move from v = u − step·e_d moves
    the command by Ā·step·e_d."""
    columns = []
    for e in np.eye(4):
        som.reset()
        theta0 = som.act(u)
        columns.append((som.act(u, u - step * e) - theta0) / step)
    return np.array(columns).T


def test_local_fit_contracts_to_second_order_in_the_lattice_spacing():
    """‖I − Ā J(θ*)‖ is the fraction of the error a fine move leaves near the target. With the
    winner's exact A_s it is what J changes between θ_s and θ*: first order in the grid step
    h, so halving h halves it. The fit of the box's A_r is second order: it falls ~4×.
    Measured (median over 60 targets): winner 0.117 -> 0.055, fit 0.065 -> 0.017."""
    rng = np.random.default_rng(5)
    targets = rng.uniform(-0.4, 0.4, size=(60, 3))  # inside the grid, off its points
    contraction = {}
    for side in (6, 11):  # h = 0.24 and 0.12 rad
        for abar in ("average", "local-fit"):
            som = known_map(abar, side)
            norms = [
                np.linalg.norm(np.eye(3) - measured_abar(som, pixels(t)) @ jacobian(t), 2)
                for t in targets
            ]
            contraction[abar, side] = np.median(norms)
    assert 1.6 < contraction["average", 6] / contraction["average", 11] < 2.6
    assert contraction["local-fit", 6] / contraction["local-fit", 11] > 3.0
    assert contraction["local-fit", 11] < 0.4 * contraction["average", 11]


def test_a_field_linear_along_the_surface_is_recovered_at_the_target():
    """A_r = B_0 + B_1 (w_r − c) for w_r on a 3-D plane of the 4-D input: the fit returns
    the field's value at u (the ridge biases the slopes by ~1e-3 of themselves)."""
    grid = Lattice((5, 5, 5))
    rng = np.random.default_rng(1)
    rows = np.linalg.qr(rng.normal(size=(4, 3)))[0].T  # orthonormal (3, 4)
    plane = rows * np.array([[1.0], [0.7], [0.5]])  # the surface's directions in input space
    w = grid.coords @ plane + rng.normal(size=4)  # (N, 4)
    b0, b1 = rng.normal(size=(3, 4)), rng.normal(size=(3, 4, 4)) * 0.1
    A = b0 + np.einsum("jde,ne->njd", b1, w)
    s = int(np.ravel_multi_index((2, 2, 2), grid.shape))
    u = w[s] + np.array([0.3, -0.2, 0.4]) @ plane  # between neurons of s's box
    expected = b0 + b1 @ u
    np.testing.assert_allclose(local_abar(grid, s, u, w, A), expected, atol=1e-2 * np.abs(b1).max())
    # beyond the box the value at its edge, not an extrapolation (the plane's directions are
    # the box's principal ones, so its edge along the first is the neurons at offset +1)
    far = w[s] + np.array([5.0, 0.0, 0.0]) @ plane
    edge = w[s] + np.array([1.0, 0.0, 0.0]) @ plane
    np.testing.assert_allclose(local_abar(grid, s, far, w, A), b0 + b1 @ edge, atol=1e-2)


def test_a_box_too_small_to_fit_gives_the_winners_A():
    grid = Lattice((3,))  # 1-D: a box of at most 3 neurons, too few for 2 slopes + 1
    w, A = np.arange(6.0).reshape(3, 2), np.arange(12.0).reshape(3, 2, 2)
    np.testing.assert_array_equal(local_abar(grid, 1, np.array([2.0, 3.5]), w, A), A[1])


def _train(kernel: str, abar: str, trials: int = 300) -> tuple[VisuomotorSOM, np.ndarray]:
    image = np.array([320.0, 240.0, 320.0, 240.0])
    som = VisuomotorSOM(LOWER, UPPER, t_max=200, rng=3, input_high=image, kernel=kernel, abar=abar)
    rng = np.random.default_rng(0)
    commands = []
    for _ in range(trials):
        u = rng.uniform(0.0, image)
        v0, v1, v2 = (u + rng.normal(0.0, s, 4) for s in (5.0, 1.0, 0.3))
        som.reset()
        theta0, theta1 = som.act(u), som.act(u, v0, explore=True)
        som.learn(u, theta0, v0, theta1, v1)
        som.reset()  # then the moves of an evaluation: coarse and three fine, no exploration
        commands.append([som.act(u), som.act(u, v0), som.act(u, v1), som.act(u, v2)])
    return som, np.array(commands)


def test_the_map_learned_does_not_depend_on_the_fine_moves_abar():
    """Exploratory (training) fine moves keep the averaged Ā, so one map serves both."""
    fit, _ = _train("numpy", "local-fit")
    average, _ = _train("numpy", "average")
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(fit, name), getattr(average, name))


@pytest.mark.skipif(not kernels.available(), reason="numba not installed")
def test_compiled_and_numpy_fine_moves_with_the_local_fit_agree():
    """Tolerance as in tests/test_kernels.py: sums over neurons in another order."""
    fast, fast_commands = _train("numba", "local-fit")
    ref, ref_commands = _train("numpy", "local-fit")
    np.testing.assert_array_equal(fast.w, ref.w)
    np.testing.assert_allclose(fast_commands, ref_commands, rtol=0, atol=1e-12)
    _, average = _train("numpy", "average")
    assert np.abs(ref_commands[:, 1:] - average[:, 1:]).max() > 1e-3  # the option does act
