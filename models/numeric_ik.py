"""Numerical inverse kinematics of a point: damped least squares within the joint ranges.

For arms without a closed form (the arms generated from a DH table, a user's MJCF). The step
Δθ = Jᵀ (J Jᵀ + λ² I)⁻¹ e is the minimum-norm correction, so a redundant arm stays near its start;
each step is clipped into the joint ranges (a projected iteration).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: m: a solution puts the point this close to its target.
TOLERANCE = 1e-11
DAMPING = 1e-3  # m: λ, which keeps steps near a singularity bounded
MAX_STEP = 0.5  # rad: the longest step (norm over the joints)
ITERATIONS = 200
#: Restarts from random joint vectors (seeded: the same points give the same joints).
RESTARTS = 8
RESTART_SEED = 0


def _iterate(forward, jacobian, points, theta, lower, upper) -> tuple[np.ndarray, np.ndarray]:
    for _ in range(ITERATIONS):
        error = points - forward(theta)  # (N, 3)
        open_ = np.linalg.norm(error, axis=-1) > TOLERANCE
        if not open_.any():
            break
        J = jacobian(theta[open_])  # (M, 3, J)
        JJt = J @ np.swapaxes(J, -1, -2) + DAMPING**2 * np.eye(3)
        step = (np.swapaxes(J, -1, -2) @ np.linalg.solve(JJt, error[open_][..., None]))[..., 0]
        norm = np.linalg.norm(step, axis=-1, keepdims=True)
        step *= np.minimum(1.0, MAX_STEP / np.maximum(norm, 1e-300))
        theta[open_] = np.clip(theta[open_] + step, lower, upper)
    error = np.linalg.norm(points - forward(theta), axis=-1)
    return theta, np.isfinite(error) & (error <= TOLERANCE)


def solve_positions(
    forward: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    points: np.ndarray,
    start: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Joints that put the point at ``points``.

    Args:
        forward: joints (N, J) -> point (N, 3), m; jacobian: joints (N, J) -> (N, 3, J), m/rad.
        points: targets (N, 3), m; start: first guesses (N, J), rad.
        lower, upper: joint ranges (J,), rad.
    Returns:
        joints (N, J), finite and in range; reachable (N,) bool: within :data:`TOLERANCE` of the
        target (where not, the joints of the closest approach from ``start``).
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    start = np.clip(np.nan_to_num(np.array(start, dtype=float)), lower, upper)
    theta, solved = _iterate(forward, jacobian, points, start, lower, upper)
    rng = np.random.default_rng(RESTART_SEED)
    for _ in range(RESTARTS):
        if solved.all():
            break
        retry = ~solved
        guess = rng.uniform(lower, upper, size=(int(retry.sum()), len(lower)))
        found, ok = _iterate(forward, jacobian, points[retry], guess, lower, upper)
        idx = np.flatnonzero(retry)[ok]
        theta[idx], solved[idx] = found[ok], True
    return theta, solved
