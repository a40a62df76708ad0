"""ExactServo: the floor of feedback control through given cameras. Exact IK for the coarse move,
then fine moves that servo the sensed marker onto the sensed target with the exact Jacobian of
the pixels:

    θ_{k+1} = clip(θ_k + J(θ_k)⁺ (u − v_k)),   J = ∂pixels/∂θ = ∂project/∂p · ∂p/∂θ  (4, J)

(the map's fine move with a perfect Ā at the arm's pose). Near the target a move leaves an
error of second order in the last one, so after two or three moves what is left is what the
sensing allows a feedback controller: the place where the *sensed* marker meets the *sensed*
target. Exact IK (``AnalyticIK``) instead triangulates the target and is blind after its move:
its error is the target's sensing error alone. Servoing adds the marker's sensing error, so
with sensing of equal quality at both markers the servo floor lies above the IK floor.

A diagnostic baseline: it uses the exact kinematics and camera model, as ``AnalyticIK`` does.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from learners.base import Controller, check_pixels
from learners.baselines.analytic_ik import AnalyticIK

Project = Callable[[np.ndarray], np.ndarray]  # (N, 3) world points -> (N, 4) pixels
#: Step (m) of the central differences of the projection (a smooth ratio of linear maps: the
#: truncation error is ~1e-12 of the derivative at camera distances of metres).
PROJECT_STEP = 1e-6


class ExactServo(Controller):
    """Exact IK, then fine moves with the exact pixel Jacobian (see the module docstring).

    Args:
        ik: the exact IK of the arm behind the cameras (its ``arm`` gives ∂p/∂θ).
        project: world points (N, 3) -> pixels (N, 4) of the same cameras, e.g.
            ``env.unwrapped.nominal_stereo.project``.
    """

    def __init__(self, ik: AnalyticIK, project: Project) -> None:
        if not callable(project):
            raise TypeError("project must be callable: (N, 3) world points -> (N, 4) pixels")
        self.ik, self.project = ik, project
        self._cmd: np.ndarray | None = None

    def reset(self) -> None:
        self._cmd = None

    def pixel_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """∂pixels/∂θ (4, J) at joints θ (J,), px/rad."""
        arm = self.ik.arm
        p = arm.forward(theta[None])[0]  # (3,)
        steps = np.vstack((np.eye(3), -np.eye(3))) * PROJECT_STEP + p  # (6, 3)
        pixels = self.project(steps)  # (6, 4)
        d_project = ((pixels[:3] - pixels[3:]) / (2 * PROJECT_STEP)).T  # (4, 3)
        return d_project @ arm.jacobian(theta[None])[0]

    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        """Exact IK for u (4,); given v (4,), the servo step from the previous command."""
        u = check_pixels("u", u)
        if v is None:
            self._cmd = self.ik.act(u)
            return self._cmd.copy()
        v = check_pixels("v", v)
        if self._cmd is None:
            raise ValueError("a fine move act(u, v) needs a coarse act(u) first (after reset)")
        step = np.linalg.pinv(self.pixel_jacobian(self._cmd)) @ (u - v)
        self._cmd = np.clip(self._cmd + step, self.ik.arm.lower, self.ik.arm.upper)
        return self._cmd.copy()
