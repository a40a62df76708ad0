"""The lattice of a Kohonen map: neuron grid coordinates and Gaussian neighbourhoods, with the
tables that make a neighbourhood lookup cheap precomputed once."""

from __future__ import annotations

import math

import numpy as np

#: Neighbourhood weights below this are dropped (truncation for speed: an update changes by
#: less than 1e-6 of itself; the RIACS and PUMA figures are the same to 3 digits as with 1e-12).
H_CUTOFF = 1e-6
_LOG_CUTOFF = math.log(1.0 / H_CUTOFF)
#: Above this fraction of the lattice, a neighbourhood is handled as the whole map (views and
#: whole-array arithmetic beat gathering and scattering most of the rows).
_WHOLE_MAP_FRACTION = 0.25
_ONE = np.ones(1)
_ONE.flags.writeable = False


class Lattice:
    """Neurons on a grid of ``shape`` (C order) and their weights h = exp(−|r − s|² / 2σ²)."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.shape = tuple(shape)
        self.coords = np.indices(self.shape).reshape(len(self.shape), -1).T  # (N, L)
        d2 = ((self.coords[:, None, :] - self.coords[None, :, :]) ** 2).sum(-1)  # (N, N)
        self._d2 = d2.astype(float)  # (N, N) squared lattice distances
        self._order = np.argsort(d2, axis=1, kind="stable")  # (N, N) nearest first
        self._d2_sorted = np.take_along_axis(self._d2, self._order, axis=1)  # (N, N)
        self._d2_max = int(d2.max())
        self._count = (d2[:, :, None] <= np.arange(self._d2_max + 1)).sum(1)  # (N, d2_max + 1)
        self._whole = _WHOLE_MAP_FRACTION * len(self.coords)
        self._memo_key: tuple[int, float] | None = None

    def cutoff_radius2(self, sigma: float) -> int:
        """Largest squared lattice distance whose weight is above H_CUTOFF."""
        return min(int(2.0 * sigma * sigma * _LOG_CUTOFF), self._d2_max)

    def neighbours(self, s: int, sigma: float) -> tuple[slice | np.ndarray, np.ndarray]:
        """Neurons whose weight around winner ``s`` is above the cut-off, and their weights.

        Returns:
            index: ``slice(s, s + 1)`` for the winner alone, ``slice(None)`` for (most of) the
                map, with h = 0 beyond the cut-off, else the neurons' indices, nearest first.
            h: (K,) weights in the order of ``index``.
        """
        if self._memo_key == (s, sigma):  # the coarse move's σ' neighbourhood, again in learn
            return self._memo
        self._memo_key, self._memo = (s, sigma), self._neighbourhood(s, sigma)
        return self._memo

    def _neighbourhood(self, s: int, sigma: float) -> tuple[slice | np.ndarray, np.ndarray]:
        r2 = self.cutoff_radius2(sigma)
        k = self._count[s, r2]
        if k == 1:
            return slice(s, s + 1), _ONE
        scale = -0.5 / (sigma * sigma)
        if k > self._whole:
            d2 = self._d2[s]
            h = np.exp(d2 * scale)
            h[d2 > r2] = 0.0
            return slice(None), h
        return self._order[s, :k], np.exp(self._d2_sorted[s, :k] * scale)

    def distances2(self, winners: np.ndarray) -> np.ndarray:
        """Squared lattice distances of every neuron from each winner: (M,) -> (M, N)."""
        d2 = np.empty((len(winners), len(self.coords)))
        np.put_along_axis(d2, self._order[winners], self._d2_sorted[winners], axis=1)
        return d2

    def within(self, s: int, radius: float) -> np.ndarray:
        """Brause's step neighbourhood (3.2): the neurons k with |y_k − y_s| ≤ ``radius``
        (lattice units), nearest first; each has h = 1, all others h = 0. ``radius`` < 1 leaves
        the winner alone."""
        r2 = min(math.floor(radius * radius), self._d2_max)  # squared distances are integers
        return self._order[s, : self._count[s, r2]]
