"""The pose task's marker frame: three coloured marker spheres at :data:`MARKER_OFFSETS` in a
frame, on the hand (in its tool frame, site ``tcp``) and on the object (in its own frame), the
same on every arm; where a frame's markers are, and the frame found back from them.

The hand grasps the object when the two frames coincide, and then the two marker frames coincide
too: so the goal a camera sees (the object's markers) and what the hand achieves (its own
markers) are directly comparable pixel vectors. A pose is found back from three sensed marker
points by the least-squares rigid fit of the known offsets (Kabsch), so that an error in one
marker spreads over the fit instead of tilting one axis.
"""

from __future__ import annotations

import numpy as np

from models.rotations import homogeneous

#: Marker centres (3, 3) in the hand's (and the object's) own frame, m: one row per marker, in
#: the order of :data:`MARKER_COLOURS`. Red and green at the ends of a crossbar along tool y,
#: blue below the fingers on the tool axis (``models/puma560/grasp.py`` says why).
MARKER_OFFSETS = np.array([[0.0, 0.08, 0.02], [0.0, -0.08, 0.02], [0.0, 0.0, 0.14]])
#: The object's markers' colours, in the order of :data:`MARKER_OFFSETS` (the scene's geoms
#: ``object_marker_<colour>``) ...
MARKER_COLOURS = ("red", "green", "blue")
#: ... and the hand's, pair by pair (geoms ``hand_marker_<colour>``): colours of their own, as
#: the cameras see both frames in the same images.
HAND_COLOURS = ("yellow", "cyan", "magenta")


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
