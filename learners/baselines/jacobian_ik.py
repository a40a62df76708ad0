"""JacobianIK: the numerical baseline. Triangulate the target, then iterate damped least squares on
the arm's position Jacobian from the current pose, clipping into the joint ranges every step:

    Δθ = Jᵀ (J Jᵀ + λ² I)⁻¹ (p* - f(θ)),   θ ← clip(θ + Δθ, lower, upper)

(Wampler 1986; Nakamura & Hanafusa 1986). λ bounds the step near singularities; with the
Jacobian's singular values σ ≈ 0.1-1 m the error shrinks by about λ²/(σ² + λ²) ≤ 1 % per step
near the solution. Steps are capped at :data:`MAX_STEP` rad so that the first iteration from a
distant pose does not overshoot into a joint limit.

The command of a query starts from the previous command (``reset()`` returns to the start pose).
The fine move ``act(u, v)`` re-solves for ``u`` from that previous command, which is already the
converged solution: as for the analytic baseline, what remains after the coarse move is sensing and
servo error, which the kinematic model cannot see.
"""

from __future__ import annotations

import numpy as np

from learners.base import Controller, check_pixels
from learners.baselines.analytic_ik import Triangulate
from models.arms import ArmKinematics, arm_kinematics

DAMPING = 1e-2  #: λ, m
TOLERANCE = 1e-8  #: m, position error at which a query counts as converged
MAX_ITERATIONS = 100  #: per query
MAX_STEP = 0.5  #: rad, largest joint-space step norm per iteration


class JacobianIK(Controller):
    """Damped-least-squares inverse kinematics behind the stereo rig.

    Args:
        triangulate: pixels (N, 4) -> world points (N, 3).
        arm: the arm's kinematics (:func:`models.arms.arm_kinematics`).
        start: start pose (J,) in rad, default ``arm.ready`` (a well-conditioned pose in the middle
            of the workspace); ``reset()`` returns to it.
        damping: λ in m; tolerance: m; max_iterations: per query; max_step: rad.

    Attributes:
        last_reachable: after ``act``, whether the iteration converged to within ``tolerance``
            (bool); after ``act_batch``, an (N,) mask. Otherwise the command is the in-range pose
            where the iteration stopped (closest it got), never NaN.
        last_iterations: iterations used by the last query (int) or batch ((N,) ints).
    """

    def __init__(
        self,
        triangulate: Triangulate,
        arm: ArmKinematics,
        start: np.ndarray | None = None,
        damping: float = DAMPING,
        tolerance: float = TOLERANCE,
        max_iterations: int = MAX_ITERATIONS,
        max_step: float = MAX_STEP,
    ) -> None:
        if not callable(triangulate):
            raise TypeError("triangulate must be callable: (N, 4) pixels -> (N, 3) world points")
        if not (damping > 0 and tolerance > 0 and max_iterations >= 1 and max_step > 0):
            raise ValueError(
                "damping (m), tolerance (m), max_step (rad) must be > 0 and max_iterations >= 1; "
                f"got {damping}, {tolerance}, {max_step}, {max_iterations}"
            )
        self.triangulate, self.arm = triangulate, arm
        self.damping, self.tolerance = float(damping), float(tolerance)
        self.max_iterations, self.max_step = int(max_iterations), float(max_step)
        start = arm.ready if start is None else np.asarray(start, dtype=float)
        if start.shape != (arm.n_joints,):
            raise ValueError(f"start must have shape ({arm.n_joints},), got {start.shape}")
        self.start = np.clip(start, arm.lower, arm.upper)
        self.previous = self.start.copy()
        self.last_reachable: bool | np.ndarray = True
        self.last_iterations: int | np.ndarray = 0

    @classmethod
    def for_robot(
        cls, triangulate: Triangulate, robot: str, joints: int = 3, **options
    ) -> JacobianIK:
        """JacobianIK for ``"puma560"`` (3 or 6 joints) or ``"riacs"``; options as in __init__."""
        return cls(triangulate, arm_kinematics(robot, joints), **options)

    def reset(self) -> None:
        self.previous = self.start.copy()

    def solve(
        self, points: np.ndarray, start: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Iterate from ``start`` (J,) or (N, J) towards world points (N, 3).

        Returns:
            joints (N, J) in range; converged (N,) bool; iterations (N,) int.
        """
        target = np.atleast_2d(np.asarray(points, dtype=float))  # (N, 3)
        n, J = len(target), self.arm.n_joints
        theta = np.broadcast_to(np.asarray(start, dtype=float), (n, J)).copy()
        iterations = np.zeros(n, dtype=int)
        error = target - self.arm.forward(theta)  # (N, 3)
        active = np.linalg.norm(error, axis=-1) >= self.tolerance
        damping2 = self.damping**2 * np.eye(3)
        for _ in range(self.max_iterations):
            idx = np.flatnonzero(active)
            if idx.size == 0:
                break
            jac = self.arm.jacobian(theta[idx])  # (M, 3, J)
            jjt = jac @ np.swapaxes(jac, -1, -2) + damping2  # (M, 3, 3)
            step = np.einsum("mji,mj->mi", jac, np.linalg.solve(jjt, error[idx][..., None])[..., 0])
            norm = np.linalg.norm(step, axis=-1, keepdims=True)
            step *= np.minimum(1.0, self.max_step / np.maximum(norm, 1e-300))
            theta[idx] = np.clip(theta[idx] + step, self.arm.lower, self.arm.upper)
            error[idx] = target[idx] - self.arm.forward(theta[idx])
            iterations[idx] += 1
            active[idx] = np.linalg.norm(error[idx], axis=-1) >= self.tolerance
        return theta, ~active, iterations

    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        """Joint command (J,) for target pixels u (4,), iterated from the previous command."""
        u = check_pixels("u", u)
        if v is not None:
            check_pixels("v", v)
        theta, converged, iterations = self.solve(self.triangulate(u[None, :]), self.previous)
        self.previous = theta[0].copy()
        self.last_reachable, self.last_iterations = bool(converged[0]), int(iterations[0])
        return theta[0]

    def act_batch(self, U: np.ndarray) -> np.ndarray:
        """Joint commands (N, J) for target pixels (N, 4), each iterated from the previous
        command; the previous command itself is left unchanged."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        if U.ndim != 2 or U.shape[1] != 4 or not np.all(np.isfinite(U)):
            raise ValueError(f"U must be finite pixels of shape (N, 4), got shape {U.shape}")
        theta, converged, iterations = self.solve(self.triangulate(U), self.previous)
        self.last_reachable, self.last_iterations = converged, iterations
        return theta
