"""The grasp task's reward: one function for the step and for relabelled goals (HER).

A goal is the 12 sensed pixels of three markers (``models.marker_frame.MARKER_OFFSETS``
order), each (u_left, v_left, u_right, v_right). Each marker is triangulated by the stereo rig
(:func:`envs.sensing.triangulation.triangulate_elementwise`), the frame's pose is the
least-squares rigid fit of the known offsets to the three points
(:func:`models.marker_frame.pose_from_points`), and

``reward = reward_distance + reward_orientation + reward_unseen`` with ``reward_distance`` minus
the distance (m) between the two fitted origins, ``reward_orientation`` minus ``weight`` (m/rad)
times the angle (rad) between the two fitted orientations, ``reward_unseen`` minus ``penalty``
(m) when the hand's markers were not all seen after the move, else 0.

One transition is computed as a batch of one through the same array operations as any batch
(stacked SVDs and products act matrix by matrix), so the step's reward and a relabelled batch's
have the same bits.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from envs.sensing.triangulation import CameraFloats, distance_elementwise, triangulate_elementwise
from models.marker_frame import orientation_angle, pose_from_points

#: Pixel coordinates per marker, and markers per goal.
MARKER_PIXELS, MARKERS = 4, 3


def goal_poses(cameras: Sequence[CameraFloats], goal: np.ndarray) -> np.ndarray:
    """The fitted world poses (N, 4, 4) of goals ``goal`` (12, N) px (coordinates first)."""
    points = [
        triangulate_elementwise(cameras, goal[MARKER_PIXELS * m : MARKER_PIXELS * (m + 1)])
        for m in range(MARKERS)
    ]  # per marker (x, y, z), each (N,)
    stacked = np.stack([np.stack(p, axis=-1) for p in points], axis=-2)  # (N, 3, 3)
    return pose_from_points(stacked)


def pose_reward_terms(
    cameras: Sequence[CameraFloats],
    achieved: Sequence[Any],
    desired: Sequence[Any],
    seen: bool | np.ndarray,
    penalty: float,
    weight: float,
) -> tuple[Any, Any, Any]:
    """(reward_distance, reward_orientation, reward_unseen), floats for one transition or
    arrays of the batch shape.

    Args:
        cameras: the stereo rig's two cameras as floats.
        achieved, desired: 12 pixel coordinates each, Python floats for one transition or
            arrays of the batch shape.
        seen: the hand's markers all seen, bool or bool array of the batch shape.
        penalty: what an unseen hand costs, m; weight: m per rad of orientation error.
    """
    a, d = np.asarray(achieved, dtype=float), np.asarray(desired, dtype=float)
    shape = a.shape[1:]
    a, d = a.reshape(len(a), -1), d.reshape(len(d), -1)  # (12, N)
    pose_a, pose_d = goal_poses(cameras, a), goal_poses(cameras, d)
    distance = distance_elementwise(pose_a[:, :3, 3].T, pose_d[:, :3, 3].T)  # (N,)
    angle = orientation_angle(pose_a[:, :3, :3], pose_d[:, :3, :3])  # (N,)
    if isinstance(seen, bool):  # one transition
        return -float(distance[0]), -weight * float(angle[0]), 0.0 if seen else -float(penalty)
    return (
        -distance.reshape(shape),
        -weight * angle.reshape(shape),
        np.where(seen, 0.0, -penalty),
    )
