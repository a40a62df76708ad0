"""The compiled local fit of Ā (``learners/som/local_fit_kernel.py``) against the numpy reference
``local_abar`` (LAPACK's SVD and solve), and whole evaluations through both paths.

Tolerance: both compute the same fit; they differ in the order of their sums and in how the
singular vectors and the solve are found (Jacobi rotations and Cholesky against LAPACK), each
exact to a few ulp of the quantities it works on. The Gram matrix of the fit is well
conditioned (its constant row is decoupled from the slopes, whose ridge bounds their
condition number by ~1e3), so the results agree to ~1e-13 of their size; 1e-10 bounds that
with room. Whole evaluations add the coarse move's sums in another order (``test_kernels.py``:
1e-12 rad) and three fine moves that amplify a difference of Ā by |u − v| (pixels).
"""

from __future__ import annotations

import numpy as np
import pytest

from learners.som.controller import VisuomotorSOM, kernels
from learners.som.lattice import Lattice
from learners.som.local_fit import FIT_RADIUS, FIT_RIDGE, FIT_SIGMA, local_abar
from models.riacs import LOWER, UPPER

pytestmark = pytest.mark.skipif(
    not kernels.available(), reason="numba not installed (pip install 'visuomotor[fast]')"
)
RELATIVE = 1e-10  # of max |Ā| (see the module docstring)
EVALUATION = 1e-9  # rad
IMAGE = np.array([320.0, 240.0, 320.0, 240.0])  # px


def compiled(grid: Lattice, s: int, u: np.ndarray, w: np.ndarray, A: np.ndarray) -> np.ndarray:
    """The kernel's Ā, called as the map calls it (lattice padded to 3 axes)."""
    shape = np.array((1, 1, *grid.shape)[-3:], dtype=np.int64)
    out = np.full(A.shape[1:], np.nan)
    kernels.local_fit(s, u, w, A, shape, FIT_RADIUS, FIT_SIGMA, FIT_RIDGE, out)
    return out


def assert_same_fit(grid: Lattice, s: int, u: np.ndarray, w: np.ndarray, A: np.ndarray) -> None:
    expected = local_abar(grid, s, u, w, A)
    np.testing.assert_allclose(
        compiled(grid, s, u, w, A), expected, rtol=0, atol=RELATIVE * np.abs(expected).max()
    )


def corners_edges_and_inside(grid: Lattice, rng: np.random.Generator, count: int) -> np.ndarray:
    """Every corner of the lattice, ``count`` random neurons, and each of them moved onto the
    lowest and highest face of every axis."""
    L = len(grid.shape)
    corners = np.stack(np.meshgrid(*([0, n - 1] for n in grid.shape), indexing="ij"), -1)
    inside = rng.integers(grid.shape, size=(count, L))
    faces = [np.where(np.arange(L) == a, end, inside) for a in range(L) for end in (0, -1)]
    coords = np.concatenate([corners.reshape(-1, L), inside, *faces]) % np.array(grid.shape)
    return np.unique(np.ravel_multi_index(tuple(coords.T), grid.shape))


@pytest.mark.parametrize("shape", [(12, 7, 4), (5, 4, 3), (3, 3, 3), (17, 9), (2, 6), (9,)])
@pytest.mark.parametrize("joints", [3, 6, 2])
def test_compiled_fit_equals_the_reference_on_random_maps(shape, joints):
    """Random w (spread over many scales) and A; targets near the winner and far beyond its
    box (clamped); winners at every corner, on the faces and inside. (9,) and (2, 6) hold
    boxes too small to fit (the winner's A_s), the others a few as well at their corners."""
    rng = np.random.default_rng(sum(shape) * 10 + joints)
    grid = Lattice(shape)
    for scale in (1e-3, 1.0, 300.0):
        w = rng.normal(size=(grid.size, 4)) * scale * rng.uniform(0.2, 1.0, 4)
        A = rng.normal(size=(grid.size, joints, 4))
        for s in corners_edges_and_inside(grid, rng, 20):
            for reach in (0.3, 5.0):
                assert_same_fit(grid, int(s), w[s] + rng.normal(size=4) * reach * scale, w, A)


def test_too_small_boxes_give_exactly_the_winners_A():
    """Fewer than m + 2 neurons: A_s itself, bit for bit (a 1-axis lattice for 3 slopes, a
    2×2 lattice for 4)."""
    rng = np.random.default_rng(3)
    for shape, joints in (((7,), 3), ((2, 2), 6), ((1, 4), 3)):
        grid = Lattice(shape)
        w, A = rng.normal(size=(grid.size, 4)), rng.normal(size=(grid.size, joints, 4))
        for s in range(grid.size):
            np.testing.assert_array_equal(compiled(grid, s, w[s], w, A), A[s])
            np.testing.assert_array_equal(local_abar(grid, s, w[s], w, A), A[s])


@pytest.mark.parametrize("rank", [1, 2, 3])
def test_flat_boxes_agree(rank):
    """w on a plane of ``rank`` < 4 dimensions (plus noise of 1e-9 of its size, or none):
    directions beyond the plane are ill-defined in both paths, but their z are ~0, so Ā is
    not. Slopes of 3 joints need m = 3 directions, more than a line or a plane gives."""
    rng = np.random.default_rng(rank)
    grid = Lattice((6, 5, 4))
    plane = np.linalg.qr(rng.normal(size=(4, rank)))[0].T * rng.uniform(0.5, 2.0, (rank, 1))
    for noise in (0.0, 1e-9):
        w = rng.normal(size=(grid.size, rank)) @ plane * 50.0 + 100.0
        w += rng.normal(size=w.shape) * noise * 50.0
        A = rng.normal(size=(grid.size, 3, 4))
        for s in corners_edges_and_inside(grid, rng, 10):
            for u in (w[s] + rng.normal(size=4) * 5.0, w[s] + rng.normal(size=rank) @ plane * 40):
                assert_same_fit(grid, int(s), u, w, A)


def trained(kernel: str, **options) -> VisuomotorSOM:
    """A map trained on 1,500 simulated trials (t_max 1,000: the narrowest neighbourhood at
    the end, as an evaluated map is)."""
    som = VisuomotorSOM(LOWER, UPPER, t_max=1000, rng=4, input_high=IMAGE, kernel=kernel, **options)
    rng = np.random.default_rng(8)
    for _ in range(1500):
        u = rng.uniform(0.0, IMAGE)
        v0, v1 = u + rng.normal(0.0, 5.0, 4), u + rng.normal(0.0, 1.0, 4)
        som.reset()
        theta0 = som.act(u)
        som.learn(u, theta0, v0, som.act(u, v0, explore=True), v1)
    return som


def evaluation(som: VisuomotorSOM, targets: int = 300) -> np.ndarray:
    """Commands (targets, 4, J) of evaluations: coarse, then three fine moves from sensed
    positions that approach the target."""
    rng = np.random.default_rng(9)
    commands = []
    for _ in range(targets):
        u = rng.uniform(0.0, IMAGE)
        som.reset()
        moves = [som.act(u)]
        for error in (8.0, 2.0, 0.5):  # px
            moves.append(som.act(u, u + rng.normal(0.0, error, 4)))
        commands.append(moves)
    return np.array(commands)


@pytest.mark.parametrize("options", [{}, {"refine": False}, {"lattice": (17, 9)}])
def test_evaluations_through_the_compiled_fit_equal_the_numpy_path(options):
    fast, ref = trained("numba", **options), trained("numpy", **options)
    np.testing.assert_array_equal(fast.w, ref.w)  # the same map: training keeps the average
    fast_commands, ref_commands = evaluation(fast), evaluation(ref)
    np.testing.assert_allclose(fast_commands, ref_commands, rtol=0, atol=EVALUATION)
    average = evaluation(fast.with_config(abar="average"))
    assert np.abs(fast_commands[:, 1:] - average[:, 1:]).max() > 1e-3  # the fit was used
