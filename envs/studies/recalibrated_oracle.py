"""The exact baseline re-calibrated on the changed scene: an oracle that knows every change.

``AnalyticIK`` triangulates through the nominal cameras and solves the nominal arm, so a change of
the scene (:mod:`envs.perturb`) becomes a lasting error. This oracle triangulates through the
env's current cameras and solves the current arm: the closed form of the nominal arm (base shift
taken off) as the start, then Gauss-Newton steps on the changed MuJoCo model itself,

    θ ← clip(θ + J⁺ (p − x(θ))),   J = ∂x/∂θ of the sensed site (``mj_jacSite``),

until the sensed point is within :data:`TOLERANCE` of the triangulated target. It stands for a
perfect re-calibration, which a real robot only gets by measuring the change.
"""

from __future__ import annotations

import mujoco
import numpy as np

from learners.base import Controller, check_pixels
from learners.baselines.analytic_ik import AnalyticIK

TOLERANCE = 1e-9  # m
MAX_ITERATIONS = 20


class RecalibratedIK(Controller):
    """Exact IK through the env's current cameras, on its current (perturbed) model.

    Args:
        env: a ReachEnv (or wrapper); its model is read at every query, so the oracle follows
            later changes.
    """

    def __init__(self, env) -> None:
        base = env.unwrapped
        self.env = base
        self.closed_form = AnalyticIK.for_robot(base.stereo.triangulate, base.robot, base.joints)
        self.data = mujoco.MjData(base.model)
        mujoco.mj_resetDataKeyframe(base.model, self.data, base.model.key("home").id)

    def solve(self, point: np.ndarray) -> np.ndarray:
        """Joints (J,) that put the changed arm's sensed point at ``point`` (3,), world m."""
        scene, data = self.env, self.data
        theta = self.closed_form.solve(point[None, :] - self.env.perturbation.base_shift)[0][0]
        for _ in range(MAX_ITERATIONS):
            scene.set_joints(theta, data)
            error = point - scene.sensed_point(data)
            if error @ error < TOLERANCE**2:
                break
            step = np.linalg.lstsq(scene.sensed_point_jacobian(data), error, rcond=None)[0]
            theta = np.clip(theta + step, self.env.joint_lower, self.env.joint_upper)
        return theta

    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        """Joint command (J,) for target pixels u (4,); ``v`` is not needed (exact model)."""
        u = check_pixels("u", u)
        return self.solve(self.env.stereo.triangulate(u[None, :])[0])
