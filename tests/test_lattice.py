"""Lattice: the box neighbourhoods in O(N) memory against the former full (N, N) tables, the
step neighbourhood against them and its definition, and the size of a 40³ lattice."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from learners.som.lattice import H_CUTOFF, Lattice


class FullTables:
    """The former construction, kept as the reference: (N, N) squared distances, each row
    sorted nearest first, and exp(−d²/2σ²) with d² beyond the cut-off dropped."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        coords = np.indices(shape).reshape(len(shape), -1).T  # (N, L)
        self.d2 = ((coords[:, None, :] - coords[None, :, :]) ** 2).sum(-1).astype(float)  # (N, N)
        self.order = np.argsort(self.d2, axis=1, kind="stable")

    def within(self, s: int, radius: float) -> np.ndarray:
        """Neurons within ``radius`` of s, nearest first (the former ``Lattice.within``)."""
        r2 = min(math.floor(radius * radius), int(self.d2.max()))
        return self.order[s, : int((self.d2[s] <= r2).sum())]

    def weights(self, s: int, sigma: float) -> np.ndarray:
        """(N,) h_r around winner s, 0 beyond the cut-off."""
        r2 = min(int(2.0 * sigma * sigma * math.log(1.0 / H_CUTOFF)), int(self.d2.max()))
        h = np.exp(self.d2[s] * (-0.5 / (sigma * sigma)))
        h[self.d2[s] > r2] = 0.0
        return h


def scattered(lattice: Lattice, s: int, sigma: float) -> np.ndarray:
    """The box neighbourhood of s written into a full (N,) weight vector."""
    box, h = lattice.neighbours(s, sigma)
    full = np.zeros(lattice.size)
    lattice.view(full, box)[...] = h
    return full


SHAPES = [(12, 7, 4), (5, 3), (9,), (4, 3, 2, 3)]


@pytest.mark.parametrize("shape", SHAPES)
def test_box_neighbourhoods_equal_the_full_tables_for_widths_and_winners_at_edges(shape):
    lattice, ref = Lattice(shape), FullTables(shape)
    corners = [
        np.ravel_multi_index(c, shape) for c in itertools.product(*[(0, n - 1) for n in shape])
    ]
    edge = np.ravel_multi_index((0, *(n // 2 for n in shape[1:])), shape)  # middle of a face
    winners = sorted({*corners, edge, math.prod(shape) // 2, 1})
    for sigma in (0.01, 0.3, 0.7, 1.0, 1.7, 2.5, 6.0):
        for s in winners:
            got, want = scattered(lattice, int(s), sigma), ref.weights(int(s), sigma)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)


def test_weights_are_the_same_doubles_as_the_full_tables():
    lattice, ref = Lattice((12, 7, 4)), FullTables((12, 7, 4))
    for sigma in (0.5, 2.0, 2.5):
        for s in (0, 335, 170):
            np.testing.assert_array_equal(scattered(lattice, s, sigma), ref.weights(s, sigma))


def test_distances2_equal_the_full_table_rows():
    shape = (6, 5, 3)
    lattice, ref = Lattice(shape), FullTables(shape)
    winners = np.array([0, 7, 89, 44, 44])
    np.testing.assert_array_equal(lattice.distances2(winners), ref.d2[winners])


def test_box_holds_exactly_the_neurons_with_nonzero_weight_plus_its_corners():
    lattice, ref = Lattice((12, 7, 4)), FullTables((12, 7, 4))
    s, sigma = 100, 1.3
    inside = np.zeros(lattice.size, bool)
    box, h = lattice.neighbours(s, sigma)
    lattice.view(inside, box)[...] = True
    assert np.all(inside[ref.weights(s, sigma) > 0])  # nothing with weight outside the box
    assert h.shape == tuple(b.stop - b.start for b in box)


def test_step_neighbourhood_equals_the_full_tables_and_its_definition():
    shape = (7, 6, 5)
    lattice, ref = Lattice(shape), FullTables(shape)
    coords = np.indices(shape).reshape(3, -1).T
    for s in (0, 100, 209, 17):
        for radius in (0.5, 1.0, 1.5, 2.2, 3.0, 30.0):
            got = lattice.within(s, radius)
            np.testing.assert_array_equal(got, ref.within(s, radius))  # order too
            dist = np.sqrt(((coords - coords[s]) ** 2).sum(1))
            np.testing.assert_array_equal(np.sort(got), np.flatnonzero(dist <= radius))


def test_a_40_cubed_lattice_holds_linear_memory():
    lattice = Lattice((40, 40, 40))
    tables = lattice.coords.nbytes + lattice._offset_d2.nbytes
    assert tables < 10 * 2**20  # bytes: O(N), where the former (N, N) tables took ~100 GB
    _, h = lattice.neighbours(0, 2.5)  # a corner: the box is clipped to the lattice
    assert h.shape == (14, 14, 14) and h[0, 0, 0] == 1.0
