"""The pose task of an arm generated from a DH table with a ``[grasp]`` section.

The hand's tool frame is the tcp (``models.dh_arm``, F_n after the last joint), and it carries
the marker frame of :mod:`models.marker_frame` (``models.dh_mjcf`` writes its markers). Objects
are reachable by construction: joints are drawn uniformly from the task's joint box, the task's
taught pose (the table's ``[grasp] ready``, keyframe ``grasp_ready``; else ``ready``) ± its
``joint_box`` half-widths (inside the joint ranges), and the object is put where
the hand is at them (forward kinematics); the env draws again while the cameras cannot see it
(``envs.grasp``). The exact pose IK is numerical (:func:`models.numeric_ik.solve_poses`) from
the current joints, within the command box.

Frame 0 has the world's axes (the DH base transform is a lift by ``base_height``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from models.dh_arm import DHArm, base_transform, joint_frames
from models.grasp_task import GraspTask
from models.numeric_ik import solve_poses
from models.workspace import BoxWorkspace


def tool_poses(arm: DHArm, theta: np.ndarray) -> np.ndarray:
    """The tcp's poses (..., 4, 4) in frame 0 for all n joint angles (..., n), rad."""
    T = joint_frames(arm, theta)[1].copy()
    T[..., :3, 3] -= base_transform(arm)[:3, 3]
    return T


def tool_jacobian(arm: DHArm, theta: np.ndarray) -> np.ndarray:
    """The tcp's geometric Jacobian (..., 6, n): column i is (z_i × (tcp − p_i); z_i)."""
    axes, tcp = joint_frames(arm, theta)
    z, p = axes[..., :3, 2], axes[..., :3, 3]  # (..., n, 3)
    linear = np.cross(z, tcp[..., None, :3, 3] - p)  # (..., n, 3)
    return np.swapaxes(np.concatenate([linear, z], axis=-1), -1, -2)


def grasp_ready(arm: DHArm) -> np.ndarray:
    """The pose task's taught pose (n,), rad: the table's ``[grasp] ready``, else ``ready``."""
    from models.dh_mjcf import ready_pose  # it imports models.dh_arm, which builds this task

    return ready_pose(arm) if arm.grasp_ready is None else arm.grasp_ready.copy()


def task_joint_box(arm: DHArm, ready: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``ready`` (n,) ± the table's half-widths, inside the joint ranges (rad)."""
    if arm.grasp_box is None:
        raise ValueError(f"{arm.name}'s DH table has no [grasp] section: no pose task")
    lower = np.maximum(ready - arm.grasp_box, arm.lower)
    upper = np.minimum(ready + arm.grasp_box, arm.upper)
    return lower, upper


def grasp_task(arm: DHArm) -> GraspTask:
    """The arm's :class:`~models.grasp_task.GraspTask` (module docstring); ValueError if its
    table has no ``[grasp]`` section."""
    ready = grasp_ready(arm)
    lower, upper = task_joint_box(arm, ready)
    base = base_transform(arm)[:3, 3].copy()

    def pose_ik(goal: np.ndarray, current: np.ndarray, low: np.ndarray, high: np.ndarray
                ) -> tuple[np.ndarray, bool]:  # fmt: skip
        theta, reached = solve_poses(
            lambda q: tool_poses(arm, q), lambda q: tool_jacobian(arm, q),
            goal[None], current[None], low, high,
        )  # fmt: skip
        return theta[0], bool(reached[0])

    def sample(rng: np.random.Generator, box: BoxWorkspace, where: np.ndarray, _: Any
               ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        theta = rng.uniform(lower, upper)  # (n,)
        pose = tool_poses(arm, theta)
        pose[:3, 3] += where
        return pose, theta

    return GraspTask(
        lower=arm.lower.copy(),
        upper=arm.upper.copy(),
        ready=ready,
        base=base,
        forward=lambda theta: tool_poses(arm, theta),
        jacobian=lambda theta: tool_jacobian(arm, theta),
        pose_ik=pose_ik,
        sample=sample,
        joint_box=lambda _: (lower.copy(), upper.copy()),
    )
