"""The controller interface shared by learners, exact baselines and the evaluation scripts.

A trial: the cameras see the target at pixels u (4 numbers: u_left, v_left, u_right, v_right).
``act(u)`` gives the coarse joint command; after the move the effector is sensed at v, and
``act(u, v)`` gives the next (fine) command, as often as wanted. Learners never import mujoco.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np


class Controller(ABC):
    """Camera coordinates in, absolute joint commands (radians) out."""

    @abstractmethod
    def act(self, u: np.ndarray, v: np.ndarray | None = None) -> np.ndarray:
        """Coarse command for target pixels ``u`` (4,), or, given the effector pixels ``v`` (4,)
        sensed after the previous command, the corrected command. Returns joints (J,)."""

    def act_batch(self, U: np.ndarray) -> np.ndarray:
        """Coarse commands for many targets: (N, 4) -> (N, J)."""
        return np.stack([self.act(u) for u in np.atleast_2d(U)])

    def reset(self) -> None:  # noqa: B027 - optional hook, most controllers are stateless
        """Forget the previous command (start of a new trial)."""


def check_pixels(name: str, x: np.ndarray, width: int = 4) -> np.ndarray:
    """Validate camera coordinates: shape (width,) and finite, else ValueError saying which."""
    a = np.asarray(x, dtype=float)
    if a.shape != (width,):
        raise ValueError(f"{name} must have shape ({width},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or inf: {a}; pass sensed pixels of a visible marker")
    return a
