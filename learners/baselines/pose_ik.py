"""The floors of the pose task through the cameras: exact pose IK and damped least squares.

Both see the object as 12 pixels u (three markers × (u_left, v_left, u_right, v_right), in the
order of :data:`~models.marker_frame.MARKER_OFFSETS`), triangulate the three markers with the
nominal cameras and fit the object's pose to them (:func:`~models.marker_frame.pose_from_points`).
The arm is a :class:`~models.grasp_task.GraspTask` (default: the PUMA's).

- :class:`PoseIK`: the arm's exact pose IK (the PUMA's closed form, the valid branch nearest
  the current joints, :func:`~models.puma560.grasp.nearest_pose_ik`; a generated arm's numerical
  pose IK from the current joints), the current joints being the last command, else ``start``.
- :class:`PoseJacobianIK`: damped least squares on the pose error from the current joints,
  Δθ = Jᵀ (J Jᵀ + λ² I)⁻¹ (Δp; Δφ), J the geometric Jacobian of the tool frame (m and rad rows),
  Δφ the rotation vector from the hand's orientation to the goal's.

A fine move ``act(u, v)`` re-aims from the sensed hand pose H (from v): the goal becomes
T_cmd · H⁻¹ · O, the model's pose of the last command moved by the sensed hand-to-object
transform, so that a sensing bias common to the hand and the object cancels, as in
``ExactServo``. With exact sensing H = T_cmd and the goal stays O.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from learners.base import Controller
from learners.pose_pixels import check_pose_pixels
from models.grasp_task import GraspTask
from models.marker_frame import pose_from_points
from models.robot_model import robot_model
from models.rotations import orientation_error

Triangulate = Callable[[np.ndarray], np.ndarray]  # (N, 4) pixels -> (N, 3) world points, m
DAMPING = 1e-3  #: λ of the damped least squares (m, rad)
TOLERANCE = 1e-10  #: |(Δp, Δφ)| (m, rad) at which the iteration stops
MAX_ITERATIONS = 200  #: per query
MAX_STEP = 0.3  #: rad, largest joint-space step norm per iteration


class _PoseFloor(Controller):
    """Triangulation, pose fit and fine-move re-aiming shared by the pose baselines.

    Args:
        triangulate: pixels (N, 4) -> world points (N, 3), the nominal cameras.
        base: world position (3,) of the arm's frame 0, m.
        start: joints (J,) to start from and to return to on ``reset()`` (default: the task's
            ``ready``).
        lower, upper: the box (J,) rad every command lies in (default: the joint ranges; an
            env's action space may be narrower: ``PumaGrasp-v0``'s task box).
        task: the arm (default: the PUMA's, ``models.puma560.MODEL.grasp``).
    """

    def __init__(
        self,
        triangulate: Triangulate,
        base: np.ndarray,
        start: np.ndarray | None = None,
        lower: np.ndarray | None = None,
        upper: np.ndarray | None = None,
        task: GraspTask | None = None,
    ) -> None:
        if task is None:
            task = robot_model("puma560").grasp
            assert task is not None  # the PUMA's model has its pose task
        self.task = task
        if not callable(triangulate):
            raise TypeError("triangulate must be callable: (N, 4) pixels -> (N, 3) world points")
        self.triangulate = triangulate
        self.base = np.asarray(base, dtype=float)
        if self.base.shape != (3,) or not np.all(np.isfinite(self.base)):
            raise ValueError(f"base must be a finite world position (3,), got {self.base}")
        n = task.n_joints
        start = task.ready if start is None else np.asarray(start, dtype=float)
        if start.shape != (n,) or not np.all(np.isfinite(start)):
            raise ValueError(f"start must be {n} finite joint angles (rad), got {start}")
        self.lower = task.lower.copy() if lower is None else np.maximum(lower, task.lower)
        self.upper = task.upper.copy() if upper is None else np.minimum(upper, task.upper)
        if self.lower.shape != (n,) or not np.all(self.lower <= self.upper):
            raise ValueError(f"lower {self.lower} and upper {self.upper} are not a joint box")
        self.start = np.clip(start, self.lower, self.upper)
        self.previous = self.start.copy()
        self._goal: np.ndarray | None = None  # the pose (frame 0) of the last command's goal
        self.last_reachable = True

    def reset(self) -> None:
        self.previous = self.start.copy()
        self._goal = None

    def sensed_pose(self, pixels: np.ndarray) -> np.ndarray:
        """The pose (4, 4) in frame 0 of the three markers seen at ``pixels`` (12,)."""
        points = self.triangulate(pixels.reshape(3, 4))  # (3, 3) world
        pose = pose_from_points(points)
        pose[:3, 3] -= self.base
        return pose

    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        """Joints (J,) that put the hand on the object seen at u (12,); given the hand seen at
        v (12,) after the previous command, re-aimed by the sensed hand-to-object transform."""
        u = check_pose_pixels("u", u)
        goal = self.sensed_pose(u)
        if v is not None:
            v = check_pose_pixels("v", v)
            if self._goal is None:
                raise ValueError("a fine move act(u, v) needs a coarse act(u) first (after reset)")
            hand = self.sensed_pose(v)
            goal = self.task.forward(self.previous) @ np.linalg.solve(hand, goal)
        theta, self.last_reachable = self.solve(goal, self.previous)
        self.previous, self._goal = theta, goal
        return theta.copy()

    def solve(self, goal: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, bool]:
        """Joints (J,) in range for the pose ``goal`` (4, 4, frame 0) from joints ``current``,
        and whether they reach it."""
        raise NotImplementedError


class PoseIK(_PoseFloor):
    """Exact pose IK from the sensed object pose inside the command box (module docstring).
    ``last_reachable``: the arm's pose IK reached the pose within the box (the PUMA: some branch
    had every joint in range and in the box)."""

    def solve(self, goal: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, bool]:
        return self.task.pose_ik(goal, current, self.lower, self.upper)


class PoseJacobianIK(_PoseFloor):
    """Damped least squares on the pose error (module docstring), clipped into the joint
    ranges each step. ``last_reachable``: the iteration converged to ``tolerance``.

    Args:
        damping: λ; tolerance: (m, rad); max_iterations: per query; max_step: rad.
    """

    def __init__(
        self,
        triangulate: Triangulate,
        base: np.ndarray,
        start: np.ndarray | None = None,
        damping: float = DAMPING,
        tolerance: float = TOLERANCE,
        max_iterations: int = MAX_ITERATIONS,
        max_step: float = MAX_STEP,
        lower: np.ndarray | None = None,
        upper: np.ndarray | None = None,
        task: GraspTask | None = None,
    ) -> None:
        super().__init__(triangulate, base, start, lower, upper, task)
        if not (damping > 0 and tolerance > 0 and max_iterations >= 1 and max_step > 0):
            raise ValueError(
                "damping, tolerance, max_step must be > 0 and max_iterations >= 1; got "
                f"{damping}, {tolerance}, {max_step}, {max_iterations}"
            )
        self.damping, self.tolerance = float(damping), float(tolerance)
        self.max_iterations, self.max_step = int(max_iterations), float(max_step)
        self.last_iterations = 0

    def pose_error(self, goal: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """(Δp, Δφ) (6,): position (m) and rotation vector (rad) from the tool frame at θ to
        goal."""
        T = self.task.forward(theta)
        return np.concatenate([goal[:3, 3] - T[:3, 3], orientation_error(goal[:3, :3], T[:3, :3])])

    def solve(self, goal: np.ndarray, current: np.ndarray) -> tuple[np.ndarray, bool]:
        theta = np.clip(current, self.lower, self.upper)
        error = self.pose_error(goal, theta)
        damping2 = self.damping**2 * np.eye(6)
        iterations = 0
        while np.linalg.norm(error) >= self.tolerance and iterations < self.max_iterations:
            J = self.task.jacobian(theta)  # (6, J)
            step = J.T @ np.linalg.solve(J @ J.T + damping2, error)
            step *= min(1.0, self.max_step / max(float(np.linalg.norm(step)), 1e-300))
            theta = np.clip(theta + step, self.lower, self.upper)
            error = self.pose_error(goal, theta)
            iterations += 1
        self.last_iterations = iterations
        return theta, bool(np.linalg.norm(error) < self.tolerance)
