"""The lattice of a Kohonen map: neuron grid coordinates and radial neighbourhoods, in O(N) memory.

A neighbourhood weight depends only on the squared lattice distance d² = |r − s|² (an integer),
and d² is a sum over the axes, d² = Σ_a (r_a − s_a)². So two small tables give any
neighbourhood of any winner, with no (N, N) table:

    per axis a: (n_a, n_a) squared offsets (i − j)²,
    per width:  weight[d²] for d² = 0 .. r²_cut, then 0,

and the neurons with weight > 0 lie in the box |r_a − s_a| ≤ ⌊√r²_cut⌋ around the winner, which
in C order is a strided view of any (N, ...) array. The Gaussian h = exp(−d² / 2σ²) is dropped
below H_CUTOFF; Brause's step neighbourhood (3.2), h = 1 for d ≤ radius, is :meth:`within`.
weight[d²] is computed as exp(d² · (−1/2σ²)) from the exact integer d², the same double as the
full-table construction gave, so the weights are bit-identical to it.
"""

from __future__ import annotations

import math

import numpy as np

#: Neighbourhood weights below this are dropped (truncation for speed: an update changes by
#: less than 1e-6 of itself).
H_CUTOFF = 1e-6
_LOG_CUTOFF = math.log(1.0 / H_CUTOFF)

#: Neighbourhoods and weight tables remembered (a trial asks for two widths, twice each).
_MEMO_SIZE = 4
#: A box: one slice per lattice axis.
Box = tuple[slice, ...]


class Lattice:
    """Neurons on a grid of ``shape`` (C order) and their neighbourhoods (widths and radii in
    lattice units)."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.shape = tuple(int(n) for n in shape)
        self.coords = np.indices(self.shape).reshape(len(self.shape), -1).T  # (N, L)
        self._strides = [math.prod(self.shape[a + 1 :]) for a in range(len(self.shape))]
        #: squared distance of every lattice offset, indexed by offset + (n_a − 1) per axis:
        #: Σ_a of the per-axis tables (i − (n_a − 1))², shape (2n_1 − 1, ..., 2n_L − 1)
        self._offset_d2 = np.zeros((), dtype=np.intp)
        for n in self.shape:
            self._offset_d2 = np.add.outer(self._offset_d2, (np.arange(2 * n - 1) - (n - 1)) ** 2)
        self._d2_max = sum((n - 1) ** 2 for n in self.shape)
        self._memo: dict[tuple[int, float], tuple[Box, np.ndarray]] = {}
        self._tables: dict[float, np.ndarray] = {}

    @property
    def size(self) -> int:
        return len(self.coords)

    def cutoff_radius2(self, sigma: float) -> int:
        """Largest squared lattice distance whose weight is nonzero (above H_CUTOFF)."""
        return min(int(2.0 * sigma * sigma * _LOG_CUTOFF), self._d2_max)

    def weights(self, sigma: float) -> np.ndarray:
        """weight[d²] for d² = 0 .. cutoff_radius2(σ), then one 0: (r²_cut + 2,)."""
        table = self._tables.get(sigma)
        if table is None:
            r2 = self.cutoff_radius2(sigma)
            table = np.exp(np.arange(r2 + 2, dtype=float) * (-0.5 / (sigma * sigma)))
            table[-1] = 0.0
            if len(self._tables) >= _MEMO_SIZE:  # σ(t) changes every trial: keep the last few
                self._tables.clear()
            self._tables[sigma] = table
        return table

    def box(self, s: int, r2: int) -> Box:
        """The box of neurons within squared lattice distance r2 of neuron s (one slice per
        axis; the corners beyond r2 included)."""
        reach = math.isqrt(r2)
        box = []
        for n, stride in zip(self.shape, self._strides, strict=True):
            c = s // stride % n
            box.append(slice(max(c - reach, 0), min(c + reach + 1, n)))
        return tuple(box)

    def neighbours(self, s: int, sigma: float) -> tuple[Box, np.ndarray]:
        """The box of neurons around winner ``s`` that holds every nonzero weight, and the
        weights over it (0 at the box's corners beyond the cut-off).

        Returns:
            box: one slice per axis; ``view(array, box)`` are the box's rows of an (N, ...) array.
            h: weights of shape ``box`` sizes, (b_1, ..., b_L).
        """
        key = (s, sigma)
        found = self._memo.get(key)  # the coarse move's σ' neighbourhood, again in learn
        if found is not None:
            return found
        r2 = self.cutoff_radius2(sigma)
        box = self.box(s, r2)
        h = self.weights(sigma).take(np.minimum(self._box_d2(s, box), r2 + 1))
        h.flags.writeable = False  # shared by the callers that ask again
        if len(self._memo) >= _MEMO_SIZE:
            self._memo.clear()
        self._memo[key] = box, h
        return box, h

    def view(self, array: np.ndarray, box: Box) -> np.ndarray:
        """The rows of an (N, ...) array in ``box``: a view of shape (b_1, ..., b_L, ...)."""
        return array.reshape(*self.shape, *array.shape[1:])[box]

    def distances2(self, winners: np.ndarray) -> np.ndarray:
        """Squared lattice distances of every neuron from each winner: (M,) -> (M, N)."""
        d2 = np.zeros((len(winners), self.size), dtype=np.intp)
        for c in self.coords.T:  # per axis: (M, N) += (r_a − s_a)²
            d2 += (c[None, :] - c[winners][:, None]) ** 2
        return d2

    def within(self, s: int, radius: float) -> np.ndarray:
        """Brause's step neighbourhood (3.2): the neurons k with |y_k − y_s| ≤ ``radius``
        (lattice units), nearest first (ties in index order); each has h = 1, all others
        h = 0. ``radius`` < 1 leaves the winner alone."""
        r2 = min(math.floor(radius * radius), self._d2_max)  # squared distances are integers
        box = self.box(s, r2)
        flat = np.zeros((), dtype=np.intp)
        for b, stride in zip(box, self._strides, strict=True):
            flat = np.add.outer(flat, np.arange(b.start, b.stop) * stride)  # the box's indices
        d2 = self._box_d2(s, box)
        inside = d2 <= r2
        return flat[inside][np.argsort(d2[inside], kind="stable")]

    def _box_d2(self, s: int, box: Box) -> np.ndarray:
        """Squared lattice distances from neuron s over ``box`` (a view of the offset table)."""
        offsets = tuple(
            slice(b.start - c + n - 1, b.stop - c + n - 1)
            for b, c, n in zip(box, self.coords[s].tolist(), self.shape, strict=True)
        )
        return self._offset_d2[offsets]
