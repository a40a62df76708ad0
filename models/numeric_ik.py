"""Numerical inverse kinematics of a point or a pose: damped least squares within the joint ranges.

For arms without a closed form (the arms generated from a DH table, a user's MJCF). The step
Δθ = Jᵀ (J Jᵀ + λ² I)⁻¹ e is the minimum-norm correction, so a redundant arm stays near its start;
each step is clipped into the joint ranges (a projected iteration). A point's error e is its
offset (3,), m; a pose's (6,) the position's offset and the rotation vector that turns the frame
onto the goal's (:func:`~models.rotations.orientation_error`), m and rad, with the geometric
Jacobian (m/rad and rad/rad rows).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from models.rotations import orientation_error

#: m: a solution puts the point this close to its target (a pose: |(Δp, Δφ)|, m and rad).
TOLERANCE = 1e-11
DAMPING = 1e-3  # m: λ, which keeps steps near a singularity bounded
MAX_STEP = 0.5  # rad: the longest step (norm over the joints)
ITERATIONS = 200
#: Restarts from random joint vectors (seeded: the same points give the same joints).
RESTARTS = 8
RESTART_SEED = 0


#: targets (N, ...) and joints (N, J) -> the error e (N, k) that the step closes.
Residual = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _iterate(residual: Residual, jacobian, targets, theta, lower, upper
             ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    for _ in range(ITERATIONS):
        error = residual(targets, theta)  # (N, k)
        open_ = np.linalg.norm(error, axis=-1) > TOLERANCE
        if not open_.any():
            break
        J = jacobian(theta[open_])  # (M, k, J)
        JJt = J @ np.swapaxes(J, -1, -2) + DAMPING**2 * np.eye(error.shape[-1])
        step = (np.swapaxes(J, -1, -2) @ np.linalg.solve(JJt, error[open_][..., None]))[..., 0]
        norm = np.linalg.norm(step, axis=-1, keepdims=True)
        step *= np.minimum(1.0, MAX_STEP / np.maximum(norm, 1e-300))
        theta[open_] = np.clip(theta[open_] + step, lower, upper)
    error = np.linalg.norm(residual(targets, theta), axis=-1)
    return theta, np.isfinite(error) & (error <= TOLERANCE)


def _solve(residual: Residual, jacobian, targets, start, lower, upper
           ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The iteration from ``start``, then from seeded random joints for the targets not met."""
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    start = np.clip(np.nan_to_num(np.array(start, dtype=float)), lower, upper)
    theta, solved = _iterate(residual, jacobian, targets, start, lower, upper)
    rng = np.random.default_rng(RESTART_SEED)
    for _ in range(RESTARTS):
        if solved.all():
            break
        retry = ~solved
        guess = rng.uniform(lower, upper, size=(int(retry.sum()), len(lower)))
        found, ok = _iterate(residual, jacobian, targets[retry], guess, lower, upper)
        idx = np.flatnonzero(retry)[ok]
        theta[idx], solved[idx] = found[ok], True
    return theta, solved


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
    return _solve(lambda p, theta: p - forward(theta), jacobian, points, start, lower, upper)


def pose_residual(forward: Callable[[np.ndarray], np.ndarray]) -> Residual:
    """The pose error (N, 6) of goals (N, 4, 4) at joints (N, J): (Δp, Δφ), m and rad, for a
    ``forward`` of joints (N, J) -> poses (N, 4, 4)."""

    def residual(goals: np.ndarray, theta: np.ndarray) -> np.ndarray:
        T = forward(theta)  # (N, 4, 4)
        dp = goals[..., :3, 3] - T[..., :3, 3]
        return np.concatenate([dp, orientation_error(goals[..., :3, :3], T[..., :3, :3])], -1)

    return residual


def solve_poses(
    forward: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    goals: np.ndarray,
    start: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Joints that put a frame at the poses ``goals``.

    Args:
        forward: joints (N, J) -> the frame's pose (N, 4, 4), m; jacobian: joints (N, J) ->
            its geometric Jacobian (N, 6, J): linear (m/rad) over angular (rad/rad) rows.
        goals: (N, 4, 4) in ``forward``'s coordinates; start: first guesses (N, J), rad.
        lower, upper: joint ranges (J,), rad.
    Returns:
        joints (N, J), finite and in range; reached (N,) bool: |(Δp, Δφ)| within
        :data:`TOLERANCE` (where not, the joints of the closest approach from ``start``).
    """
    goals = np.asarray(goals, dtype=float).reshape(-1, 4, 4)
    return _solve(pose_residual(forward), jacobian, goals, start, lower, upper)
