"""Standard Denavit-Hartenberg transforms, vectorised over a batch of joint vectors.

Convention (Fu, Gonzalez & Lee; Brause Fig. 2b): A_i = Rz(θ_i) · Tz(d_i) · Tx(a_i) · Rx(α_i).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DHTable:
    """One row per joint: twist α (rad), length a (m), offset d (m), joint range (rad)."""

    alpha: np.ndarray  # (n,)
    a: np.ndarray  # (n,)
    d: np.ndarray  # (n,)
    lower: np.ndarray  # (n,)
    upper: np.ndarray  # (n,)

    @property
    def n(self) -> int:
        return len(self.alpha)


def dh_transform(theta: np.ndarray, d: float, a: float, alpha: float) -> np.ndarray:
    """A_i for a batch of angles.

    Args:
        theta: joint angles, shape (...,) in radians.
    Returns:
        homogeneous transforms, shape (..., 4, 4).
    """
    theta = np.asarray(theta, dtype=float)
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros((*theta.shape, 4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, d
    T[..., 3, 3] = 1.0
    return T


def forward_frames(table: DHTable, theta: np.ndarray) -> np.ndarray:
    """All frames T_0i, i = 0..n, of a DH chain.

    Args:
        theta: joint angles, shape (..., n) in radians.
    Returns:
        transforms of frames 0..n relative to frame 0, shape (..., n + 1, 4, 4).
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape[-1] != table.n:
        raise ValueError(
            f"expected {table.n} joint angles in the last axis, got shape {theta.shape}"
        )
    frames = np.empty((*theta.shape[:-1], table.n + 1, 4, 4))
    frames[..., 0, :, :] = np.eye(4)
    for i in range(table.n):
        A = dh_transform(theta[..., i], table.d[i], table.a[i], table.alpha[i])
        frames[..., i + 1, :, :] = frames[..., i, :, :] @ A
    return frames
