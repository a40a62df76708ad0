"""Compiled kernel (numba, extra ``fast``) of the reach env's action check: a command clipped
into the joints' ranges, as :meth:`envs.reach.ReachEnv._check_action`'s numpy path computes it
(the same bits; ``tests/test_pinhole_kernels.py`` compares them). The sensing and reward
kernels are in :mod:`envs.sensing.pinhole_kernels`, whose ``ENABLED`` says whether the env
calls either.
"""

from __future__ import annotations

import math

import numpy as np

from learners.compiled import jit


@jit
def clip_command(
    action: np.ndarray,
    mid: np.ndarray,
    half: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    normalized: bool,
    command: np.ndarray,
) -> tuple[int, bool]:
    """Fills ``command`` (J,) rad with ``action`` (J,) clipped into [lower, upper] (normalised:
    first into [-1, 1], then mapped to mid + half · a); returns (-1, whether the action was
    clipped), or (j, False) for the first joint j whose action is not finite."""
    clipped = False
    for j in range(action.shape[0]):
        a = action[j]
        if not math.isfinite(a):
            return j, False
        if normalized:
            inside = min(max(a, -1.0), 1.0)
            clipped = clipped or inside != a
            command[j] = min(max(mid[j] + half[j] * inside, lower[j]), upper[j])
        else:
            c = min(max(a, lower[j]), upper[j])
            clipped = clipped or c != a
            command[j] = c
    return -1, clipped
