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

from functools import partial
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


def pose_ik(
    arm: DHArm, goal: np.ndarray, current: np.ndarray, low: np.ndarray, high: np.ndarray
) -> tuple[np.ndarray, bool]:
    """Joints (n,) rad that put the tool frame at ``goal`` (4, 4), from ``current`` (n,), within
    [low, high], and whether they reach it (:func:`models.numeric_ik.solve_poses`)."""
    theta, reached = solve_poses(
        partial(tool_poses, arm), partial(tool_jacobian, arm), goal[None], current[None], low, high
    )
    return theta[0], bool(reached[0])


def sample_pose(
    arm: DHArm,
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    box: BoxWorkspace,
    where: np.ndarray,
    _: Any,
) -> tuple[np.ndarray, np.ndarray]:
    """An object's pose (4, 4): the tool frame at joints drawn from [lower, upper] (returned
    too, (n,) rad), moved by ``where`` (3,) m."""
    theta = rng.uniform(lower, upper)  # (n,)
    pose = tool_poses(arm, theta)
    pose[:3, 3] += where
    return pose, theta


def fixed_box(lower: np.ndarray, upper: np.ndarray, _: Any) -> tuple[np.ndarray, np.ndarray]:
    """The joint box [lower, upper] whatever the objects' orientations."""
    return lower.copy(), upper.copy()


def grasp_task(arm: DHArm) -> GraspTask:
    """The arm's :class:`~models.grasp_task.GraspTask` (module docstring); ValueError if its
    table has no ``[grasp]`` section. Its functions are partials of module functions, so that
    envs pickle (``AsyncVectorEnv``)."""
    ready = grasp_ready(arm)
    lower, upper = task_joint_box(arm, ready)
    return GraspTask(
        lower=arm.lower.copy(),
        upper=arm.upper.copy(),
        ready=ready,
        base=base_transform(arm)[:3, 3].copy(),
        forward=partial(tool_poses, arm),
        jacobian=partial(tool_jacobian, arm),
        pose_ik=partial(pose_ik, arm),
        sample=partial(sample_pose, arm, lower, upper),
        joint_box=partial(fixed_box, lower, upper),
    )
