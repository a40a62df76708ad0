"""PUMA-560 closed-form inverse kinematics of a full pose (position and orientation of frame 6).

Arm joints θ1..θ3 put the wrist centre p = p6 - d6·z6 in place (Brause Fig. 5c,
:func:`~models.puma560.kinematics.wrist_ik`); the spherical wrist then turns frame 3 into the target
orientation, R36 = R03ᵀ R06 = Rz(θ4) Rx(-90°) Rz(θ5) Rx(90°) Rz(θ6) (Fu, Gonzalez & Lee
pp. 66-68). Its third column, the approach vector z6 in frame 3, is (c4 s5, s4 s5, c5), so

    θ4 = atan2(W·a_y, W·a_x),  θ5 = atan2(W·√(a_x² + a_y²), a_z),  Rz(θ6) = (R34 R45)ᵀ R36,

with the wrist flip W = +1 (θ5 ≥ 0) or -1 (θ5 ≤ 0; the same pose as (θ4 + π, -θ5, θ6 + π)).
At the wrist singularity (a_x = a_y = 0) only θ4 + θ6 is defined; θ4 = 0 is chosen.

Four arm configurations × two wrist flips give up to eight solutions of one pose.
"""

from __future__ import annotations

import numpy as np

from models.dh import dh_transform
from models.joints import wrap_into_range
from models.puma560.kinematics import CONFIGURATIONS, DH, frames, wrist_ik

D6 = DH.d[5]  #: m, wrist centre to tool point along z6
WRIST_FLIPS = (1, -1)  #: W = +1: θ5 ≥ 0; W = -1: θ5 ≤ 0
#: Below this |sin θ5| the wrist is singular and θ4 is set to 0.
SINGULAR_SIN5 = 1e-12

#: The eight solution branches in the order :func:`pose_ik_all` returns them.
BRANCHES = tuple(
    (name, arm, elbow, wrist)
    for name, (arm, elbow) in CONFIGURATIONS.items()
    for wrist in WRIST_FLIPS
)


def _rotation(theta: np.ndarray, joint: int) -> np.ndarray:
    """Rotation part of A_joint (joint 0-based) for angles of shape (...,): (..., 3, 3)."""
    return dh_transform(theta, DH.d[joint], DH.a[joint], DH.alpha[joint])[..., :3, :3]


def wrist_joints(R36: np.ndarray, wrist: int) -> np.ndarray:
    """θ4, θ5, θ6 that realise the wrist rotation R36 (frame 6 in frame 3).

    Args:
        R36: rotations, shape (..., 3, 3).
        wrist: +1 or -1, the sign of θ5 (see the module docstring).
    Returns:
        (..., 3) angles in [-π, π].
    """
    if wrist not in WRIST_FLIPS:
        raise ValueError(f"wrist must be one of {WRIST_FLIPS}, got {wrist!r}")
    ax, ay, az = R36[..., 0, 2], R36[..., 1, 2], R36[..., 2, 2]
    s5 = np.hypot(ax, ay)
    singular = s5 < SINGULAR_SIN5
    theta4 = np.where(singular, 0.0, np.arctan2(wrist * ay, wrist * ax))
    theta5 = np.arctan2(wrist * s5, az)
    R35 = _rotation(theta4, 3) @ _rotation(theta5, 4)  # (..., 3, 3)
    Rz6 = np.swapaxes(R35, -1, -2) @ R36  # = Rz(θ6)
    theta6 = np.arctan2(Rz6[..., 1, 0], Rz6[..., 0, 0])
    return np.stack([theta4, theta5, theta6], axis=-1)


def pose_ik(
    T06: np.ndarray, arm: int, elbow: int, wrist: int, reference: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """All six joints that put frame 6 at the pose ``T06``, for one solution branch.

    Args:
        T06: target poses of frame 6 in frame 0, shape (..., 4, 4), metres.
        arm, elbow: the configuration of Brause Fig. 5c (+1 RIGHT / -1 LEFT, +1 ABOVE / -1 BELOW).
        wrist: +1 or -1, the wrist flip.
        reference: angles (..., 6) to stay close to when a joint range allows several turns.
    Returns:
        theta, shape (..., 6), mapped into the joint ranges (clipped where impossible, never NaN);
        valid, shape (...,): the pose is reachable in this branch with every joint in range.
    """
    T06 = np.asarray(T06, dtype=float)
    R06 = T06[..., :3, :3]
    p = T06[..., :3, 3] - D6 * R06[..., :, 2]  # (..., 3) wrist centre
    arm_joints, reachable = wrist_ik(p, arm, elbow)
    zeros = np.zeros_like(arm_joints)
    R03 = frames(np.concatenate([arm_joints, zeros], axis=-1))[..., 3, :3, :3]
    R36 = np.swapaxes(R03, -1, -2) @ R06
    theta = np.concatenate([arm_joints, wrist_joints(R36, wrist)], axis=-1)
    theta, in_range = wrap_into_range(theta, DH.lower, DH.upper, reference)
    return theta, reachable & in_range


def pose_ik_all(T06: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The eight solutions of each pose, in the order of :data:`BRANCHES`.

    Returns:
        theta, shape (..., 8, 6); valid, shape (..., 8).
    """
    solved = [pose_ik(T06, arm, elbow, wrist) for _, arm, elbow, wrist in BRANCHES]
    return np.stack([s[0] for s in solved], axis=-2), np.stack([s[1] for s in solved], axis=-1)
