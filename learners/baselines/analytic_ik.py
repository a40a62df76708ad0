"""AnalyticIK: the exact baseline. Triangulate the target from its pixels, then solve the
closed-form inverse kinematics (PUMA: Brause Fig. 5c, and the wrist for 6 joints; RIACS:
``robot3dinv``).

The command is exact for the sensed target, so the fine move ``act(u, v)`` has nothing to learn
from ``v``: it re-solves for ``u`` and returns the same command. What remains after the coarse
move is sensing error (pixel quantisation, marker detection) and servo error, which an exact
inverse kinematics cannot see.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from learners.base import Controller, check_pixels
from models.arms import ArmKinematics, arm_kinematics

Triangulate = Callable[[np.ndarray], np.ndarray]  # (N, 4) pixels -> (N, 3) world points, m


class AnalyticIK(Controller):
    """Closed-form inverse kinematics behind the stereo rig.

    Args:
        triangulate: pixels (N, 4) -> world points (N, 3), e.g.
            ``env.unwrapped.stereo.triangulate``.
        arm: the arm's kinematics (:func:`models.arms.arm_kinematics`).

    Attributes:
        last_reachable: after ``act``, whether the target was reachable with every joint in range
            (bool); after ``act_batch``, an (N,) bool mask. Unreachable targets still get a finite,
            in-range command (the arm stretched towards the target, angles clipped).
    """

    def __init__(self, triangulate: Triangulate, arm: ArmKinematics) -> None:
        if not callable(triangulate):
            raise TypeError("triangulate must be callable: (N, 4) pixels -> (N, 3) world points")
        self.triangulate = triangulate
        self.arm = arm
        self.last_reachable: bool | np.ndarray = True

    @classmethod
    def for_robot(
        cls,
        triangulate: Triangulate,
        robot: str,
        joints: int = 3,
        configuration: str = "right-above",
    ) -> AnalyticIK:
        """AnalyticIK for ``"puma560"`` (3 or 6 joints, ``configuration`` of Brause Fig. 5c,
        default right-above) or ``"riacs"``."""
        return cls(triangulate, arm_kinematics(robot, joints, configuration))

    def solve(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joints for world points (N, 3): (joints (N, J) finite and in range, reachable (N,))."""
        return self.arm.inverse(np.atleast_2d(points), None)

    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        """Joint command (J,) for target pixels u (4,); ``v`` is checked but not needed."""
        u = check_pixels("u", u)
        if v is not None:
            check_pixels("v", v)
        theta, reachable = self.solve(self.triangulate(u[None, :]))
        self.last_reachable = bool(reachable[0])
        return theta[0]

    def act_batch(self, U: np.ndarray) -> np.ndarray:
        """Joint commands (N, J) for target pixels (N, 4); ``last_reachable`` becomes the mask."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        if U.ndim != 2 or U.shape[1] != 4 or not np.all(np.isfinite(U)):
            raise ValueError(f"U must be finite pixels of shape (N, 4), got shape {U.shape}")
        theta, reachable = self.solve(self.triangulate(U))
        self.last_reachable = reachable
        return theta
