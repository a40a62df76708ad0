"""Rotations as vectors and matrices (Rodrigues), vectorised over leading axes."""

from __future__ import annotations

import numpy as np


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices: (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack(
        [np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2
    )


def rotvec_to_matrix(rotvec: np.ndarray) -> np.ndarray:
    """Rodrigues' formula: rotation vectors (..., 3) (rad) -> rotation matrices (..., 3, 3)."""
    r = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(r, axis=-1)[..., None, None]
    K = skew(r)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    a = np.where(small, 1.0 - angle**2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    return np.eye(3) + a * K + b * (K @ K)


def matrix_to_rotvec(R: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> rotation vectors (..., 3), angle in [0, π] (rad)."""
    R = np.asarray(R, dtype=float)
    cos = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    w = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
        axis=-1,
    )  # 2 sin(angle) · axis
    sin = np.linalg.norm(w, axis=-1) / 2.0
    angle = np.arctan2(sin, cos)  # accurate near 0 and π, where arccos is not
    scale = np.where(
        sin > 1e-6, angle / (2.0 * np.where(sin > 1e-6, sin, 1.0)), 0.5 + angle**2 / 12
    )
    out = w * scale[..., None]
    # Near π the antisymmetric part vanishes: take the axis from the symmetric part instead,
    # (R + Rᵀ)/2 = cos·I + (1 - cos)·axis axisᵀ.
    near_pi = angle > np.pi - 1e-3
    if np.any(near_pi):
        Rn, c = R[near_pi], cos[near_pi][..., None, None]
        S = ((Rn + np.swapaxes(Rn, -1, -2)) / 2.0 - c * np.eye(3)) / (1.0 - c)  # axis axisᵀ
        k = np.argmax(np.diagonal(S, axis1=-2, axis2=-1), axis=-1)
        axis = S[np.arange(len(k)), k] / np.sqrt(S[np.arange(len(k)), k, k])[..., None]
        sign = np.where(np.sum(axis * w[near_pi], -1) < 0, -1.0, 1.0)[..., None]
        out[near_pi] = sign * axis * angle[near_pi][..., None]
    return out


def orientation_error(R_desired: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Rotation vector (world frame, rad) that turns R into R_desired: log(R_d·Rᵀ), (..., 3)."""
    return matrix_to_rotvec(np.asarray(R_desired) @ np.swapaxes(np.asarray(R), -1, -2))


def homogeneous(rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """4×4 transforms from rotations (..., 3, 3) and positions (..., 3), broadcast."""
    rotation, position = np.asarray(rotation, dtype=float), np.asarray(position, dtype=float)
    shape = np.broadcast_shapes(rotation.shape[:-2], position.shape[:-1])
    T = np.zeros((*shape, 4, 4))
    T[..., :3, :3] = rotation
    T[..., :3, 3] = position
    T[..., 3, 3] = 1.0
    return T
