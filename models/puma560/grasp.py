"""The PUMA 560's pose task: where the hand must be, and how its pose is seen.

The target object and the hand carry the same frame of three coloured marker spheres, at
:data:`MARKER_OFFSETS` in their own frames (the hand's frame is DH frame 6, the tool point
``tcp``). The hand grasps the object when the two frames coincide, and then the two marker
frames coincide too: so the goal a camera sees (the object's markers) and what the hand achieves
(its own markers) are directly comparable pixel vectors, and goal relabelling works unchanged.

Where the markers sit. The cameras look at the workspace from the front (world +y) and above;
at :data:`NOMINAL_ORIENTATION` the tool's x axis points along their line of sight, its y axis
across the images and its z axis (the approach direction) down. Offsets along tool x therefore
hardly move a marker in the images, and markers at the tool point itself are hidden by the
fingers and the wrist. The three markers lie in the tool's y-z plane instead: red and green on
a 160 mm crossbar along tool y, 20 mm beyond the flange (beside the wrist's silhouette, outside
the fingers), blue 140 mm down the tool axis below the fingertips, a T whose sides are seen
nearly face-on by both cameras. Over 2 000 poses of :func:`sample_grasp_pose` (projection at
320 × 240) the closest two markers are at least 9.4 px apart in both images (1 % of poses below
12.4 px, median 22.6 px; 0.1 m offsets along tool x and y left 1 % below 3.1 px), and every
marker is at least 5 px inside both images in 99.75 % of poses (the rest are poses at the
bottom or the sides of the box, where the blue marker or one end of the crossbar nears the
border).

A pose is found back from three sensed marker points by the least-squares rigid fit of the
known offsets (Kabsch), so that an error in one marker spreads over the fit instead of tilting
one axis.

All positions are in metres; the world frame is DH frame 0 shifted by
:data:`~models.puma560.BASE_POS` (same axes).
"""

from __future__ import annotations

import math

import numpy as np

from models.puma560.inverse import pose_ik
from models.puma560.kinematics import frames
from models.rotations import homogeneous, rotvec_to_matrix
from models.workspace import BoxWorkspace

#: The taught keyframe ``ready`` (rad), the one pose a learner is given.
READY = np.array([-1.2963, -2.2265, -0.2073, 0.0, -0.818, 0.2745])
#: Marker centres (3, 3) in the hand's (and the object's) own frame, m: one row per marker, in
#: the order of :data:`MARKER_COLOURS`. Red and green at the ends of a crossbar along tool y,
#: blue below the fingers on the tool axis (see the module docstring for why).
MARKER_OFFSETS = np.array([[0.0, 0.08, 0.02], [0.0, -0.08, 0.02], [0.0, 0.0, 0.14]])
#: The markers' colours, in the order of :data:`MARKER_OFFSETS` (the scene's geoms
#: ``hand_marker_<colour>`` and ``object_marker_<colour>``).
MARKER_COLOURS = ("red", "green", "blue")
#: The object's orientation without tilt: the hand's orientation at ``ready`` (world axes).
NOMINAL_ORIENTATION = frames(READY)[6, :3, :3]
#: Largest tilt of the object from :data:`NOMINAL_ORIENTATION` (rad), about any axis.
MAX_TILT = math.radians(30.0)
#: The branch a learner keeps (right arm, elbow above, wrist flip -1: ``ready``'s branch).
BRANCH = (1, 1, -1)


def marker_points(pose: np.ndarray) -> np.ndarray:
    """World centres (..., 3, 3) of the three markers of frames at ``pose`` (..., 4, 4)."""
    pose = np.asarray(pose, dtype=float)
    return pose[..., None, :3, 3] + MARKER_OFFSETS @ np.swapaxes(pose[..., :3, :3], -1, -2)


def pose_from_points(points: np.ndarray) -> np.ndarray:
    """The pose (..., 4, 4) whose markers best fit ``points`` (..., 3, 3) (Kabsch).

    Exact for noise-free points; NaN where a point is NaN.
    """
    points = np.asarray(points, dtype=float)
    model_centre = MARKER_OFFSETS.mean(axis=0)
    centre = points.mean(axis=-2)
    P = MARKER_OFFSETS - model_centre  # (3, 3) model, rows
    Q = points - centre[..., None, :]  # (..., 3, 3) seen, rows
    H = np.swapaxes(P, -1, -2) @ Q  # (..., 3, 3) = Σ p qᵀ
    bad = ~np.isfinite(H).all(axis=(-2, -1))
    H = np.where(bad[..., None, None], np.eye(3), H)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.swapaxes(Vt, -1, -2) @ np.swapaxes(U, -1, -2)))
    D = np.zeros((*d.shape, 3, 3))
    D[..., 0, 0] = D[..., 1, 1] = 1.0
    D[..., 2, 2] = d
    R = np.swapaxes(Vt, -1, -2) @ D @ np.swapaxes(U, -1, -2)
    position = centre - model_centre @ np.swapaxes(R, -1, -2)
    pose = homogeneous(R, position)
    pose[bad] = np.nan
    return pose


def orientation_angle(R_a: np.ndarray, R_b: np.ndarray) -> np.ndarray:
    """The angle (rad, in [0, π]) of the rotation between orientations (..., 3, 3)."""
    R = np.swapaxes(np.asarray(R_a), -1, -2) @ np.asarray(R_b)
    cos = (np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0
    # atan2 of |sin| and cos: accurate near 0, where arccos loses half the digits.
    w = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1
    )
    return np.arctan2(np.linalg.norm(w, axis=-1) / 2.0, cos)


def sample_grasp_pose(
    rng: np.random.Generator, wrist_box: BoxWorkspace, base: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One object pose (4, 4, world) and the joints (6,) that grasp it in :data:`BRANCH`.

    The wrist centre is drawn uniformly from ``wrist_box`` (world), the orientation uniformly
    from the ball of rotations within :data:`MAX_TILT` of :data:`NOMINAL_ORIENTATION`; a draw
    whose branch has a joint out of range is drawn again. ``base``: world position of frame 0.
    """
    from models.puma560.inverse import D6

    while True:
        wrist = wrist_box.sample(rng, 1)[0]
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = MAX_TILT * rng.random() ** (1.0 / 3.0)  # uniform in the ball of rotation vectors
        R = rotvec_to_matrix(axis * angle) @ NOMINAL_ORIENTATION
        tool = wrist + D6 * R[:, 2]
        theta, valid = pose_ik(homogeneous(R, tool - base), *BRANCH)
        if valid:
            return homogeneous(R, tool), theta
