"""Joint ranges: bring angles that an inverse kinematics wrapped to [-π, π] into a joint's range.

Revolute joints with ranges wider than 2π (PUMA joint 6: ±266°) or off-centre ranges (PUMA joint
3: -45°..225°) reach an angle θ also as θ ± 2π; :func:`wrap_into_range` picks that representative.
"""

from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi
#: Turns tried on each side: θ + 2πk for k = -2..2 covers ranges up to 4π wide.
_TURNS = np.arange(-2, 3)


def wrap_into_range(
    theta: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    reference: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The representative θ + 2πk of each angle that lies in [lower, upper].

    Where several turns k are in range, the one closest to ``reference`` is taken (without a
    reference, the smallest |k|). Where none is, the angle is clipped to the nearer range end.

    Args:
        theta: angles, shape (..., J), rad.
        lower, upper: joint ranges, shape (J,), rad.
        reference: angles to stay close to (e.g. the previous command), broadcastable to theta.
    Returns:
        angles in range, shape (..., J), always finite for finite input; in_range, shape (...,)
        bool: every joint had a representative inside its range (nothing was clipped).
    """
    theta = np.asarray(theta, dtype=float)
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    candidates = theta[..., None] + TWO_PI * _TURNS  # (..., J, K)
    lo, hi = lower[:, None], upper[:, None]
    inside = (candidates >= lo) & (candidates <= hi)  # (..., J, K)
    if reference is None:
        preference = np.broadcast_to(np.abs(_TURNS).astype(float), candidates.shape)
    else:
        preference = np.abs(candidates - np.asarray(reference, dtype=float)[..., None])
    outside = np.maximum(lo - candidates, candidates - hi)  # > 0 when out of range
    # In-range candidates rank by preference; out-of-range ones after all of them, by distance.
    rank = np.where(inside, preference, np.inf)
    fallback = np.where(inside.any(axis=-1, keepdims=True), np.inf, outside)
    best = np.argmin(np.minimum(rank, fallback), axis=-1)[..., None]  # (..., J, 1)
    chosen = np.take_along_axis(candidates, best, axis=-1)[..., 0]
    return np.clip(chosen, lower, upper), np.all(inside.any(axis=-1), axis=-1)
