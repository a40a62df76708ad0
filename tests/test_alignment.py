"""The map's results do not depend on where its arrays lie in memory.

numpy's and OpenBLAS's reductions and products can take different SIMD paths for different
alignments, so the same values at new addresses (as after a checkpoint is loaded) could round
differently. A map that has learned is copied to arrays at every 8-byte offset within a 64-byte
cache line; coarse moves, exploratory and local-fit fine moves and learning then continue bit for
bit as from the original arrays, with the compiled and the numpy paths.
"""

from __future__ import annotations

import numpy as np
import pytest

from learners import VisuomotorSOM
from learners.som import kernels

IMAGE = np.array([320.0, 240.0, 320.0, 240.0])
KERNELS = ["numpy", *(["numba"] if kernels.available() else [])]


def at_offset(a: np.ndarray, offset: int) -> np.ndarray:
    """A copy of ``a`` whose data starts ``offset`` bytes past a 64-byte boundary."""
    buffer = np.empty(a.nbytes + 128, dtype=np.uint8)
    start = (-buffer.ctypes.data) % 64 + offset
    out = buffer[start : start + a.nbytes].view(a.dtype).reshape(a.shape)
    out[...] = a
    return out


def continue_training(kernel: str, offset: int | None) -> np.ndarray:
    """Commands of 30 more trials and the final arrays, after 50 trials of learning."""
    rng = np.random.default_rng(3)
    som = VisuomotorSOM(np.zeros(3), np.full(3, 2.0), lattice=(6, 4, 3), rng=1, kernel=kernel,
                        input_low=np.zeros(4), input_high=IMAGE)  # fmt: skip
    out = []
    for trial in range(80):
        if trial == 50 and offset is not None:  # the learned state moves to new addresses
            st = som.learned
            st.w, st.theta, st.A, st.w2 = (at_offset(a, offset) for a in
                                           (st.w, st.theta, st.A, st.w2))  # fmt: skip
        u, v0, v1 = rng.uniform(0.2, 0.8, (3, 4)) * IMAGE
        theta0 = som.act(u)
        theta1 = som.act(u, v0, explore=True)
        out += [theta0, theta1, som.act(u, v1)]  # the last: a local-fit fine move
        som.learn(u, theta0, v0, theta1, v1)
    return np.concatenate([*out, som.w.ravel(), som.theta.ravel(), som.A.ravel()])


@pytest.mark.parametrize("kernel", KERNELS)
def test_results_are_the_same_at_every_alignment(kernel):
    reference = continue_training(kernel, None)
    for offset in range(0, 64, 8):
        assert np.array_equal(continue_training(kernel, offset), reference), offset


def test_the_copies_really_lie_at_the_offsets():
    a = np.arange(12.0).reshape(3, 4)
    for offset in range(0, 64, 8):
        b = at_offset(a, offset)
        assert b.ctypes.data % 64 == offset and np.array_equal(a, b)
