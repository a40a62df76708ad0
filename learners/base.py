"""The learner interface shared by learners, exact baselines and the evaluation scripts.

A trial: the cameras see the target at pixels u (4 numbers: u_left, v_left, u_right, v_right).
``act(u)`` gives the coarse joint command; after the move the effector is sensed at v, and
``act(u, v)`` gives the next (fine) command, as often as wanted. A :class:`Learner` then learns
from the trial (u, θ0, v0, θ1, v1). Learners never import mujoco.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

#: Shorthand of the arrays in signatures (shapes are in the docstrings).
Array = np.ndarray


class Controller(ABC):
    """Camera coordinates in, absolute joint commands (radians) out.

    The trial loop (``envs.harness.trials.run_trial``) relies on ``act``, ``reset``,
    ``fine_moves_need_sight`` and ``recovery_move`` (by default no recovery); ``act_batch`` has
    a row-by-row default.
    """

    @abstractmethod
    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        """Coarse command for target pixels ``u`` (4,), or, given the effector pixels ``v`` (4,)
        sensed after the previous command, the corrected command. Returns joints (J,), rad.

        ``explore=True`` asks for an exploratory fine move (training); a controller that does
        not explore ignores it."""

    @property
    def fine_moves_need_sight(self) -> bool:
        """Whether a fine move corrects from the position sensed after the previous move, so
        that a trial cannot go on when a camera loses the marker (unless :meth:`recovery_move`
        gives a way back): True unless a controller says otherwise."""
        return True

    @property
    def recovers(self) -> bool:
        """Whether :meth:`recovery_move` may give moves: False unless a controller says
        otherwise."""
        return False

    def recovery_move(self, u: np.ndarray, attempt: int) -> np.ndarray | None:
        """Command (J,) rad of recovery attempt ``attempt`` (0, 1, ...) for target pixels ``u``
        after a move whose marker a camera did not see, or None when no attempt is left; the
        next ``act(u, v)`` corrects from where this command took the arm (v sensed there)."""
        return None

    def act_batch(self, U: np.ndarray) -> np.ndarray:
        """Coarse commands for many targets: (N, 4) -> (N, J)."""
        return np.stack([self.act(u) for u in np.atleast_2d(U)])

    def reset(self) -> None:  # noqa: B027 - optional hook, most controllers are stateless
        """Forget the previous command (start of a new trial)."""


class Learner(Controller):
    """A controller that learns from its own trials."""

    @abstractmethod
    def learn(self, u: Array, theta0: Array, v0: Array, theta1: Array, v1: Array) -> bool:
        """One trial: target u, coarse command θ0 -> sensed v0, fine command θ1 -> sensed v1.
        Returns True if it learned, False if the trial was skipped (e.g. a marker not seen)."""


class PathFollower(ABC):
    """Joint increments that follow a path of poses (``PumaTrack-v0``), one control step at a
    time: not a reach controller (no target pixels, no coarse and fine moves)."""

    @abstractmethod
    def command(
        self, theta: np.ndarray, next_error: np.ndarray, twist: np.ndarray, dt: float
    ) -> np.ndarray:
        """Joint increment Δθ (J,), rad, from the joints θ (J,), the pose error against the
        next path pose, the desired twist and the control period dt (s)."""


def check_pixels(name: str, x: np.ndarray, width: int = 4) -> np.ndarray:
    """Validate camera coordinates: shape (width,) and finite, else ValueError saying which."""
    a = np.asarray(x, dtype=float)
    if a.shape != (width,):
        raise ValueError(f"{name} must have shape ({width},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or inf: {a}; pass sensed pixels of a visible marker")
    return a
