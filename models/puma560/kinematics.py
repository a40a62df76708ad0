"""PUMA-560 kinematics after Brause (1989) Fig. 2b, Fig. 5c and eq. (5.6) (from Fu, Gonzalez & Lee).

All lengths in metres, angles in radians, positions relative to DH frame 0 (site ``base``).
"""

from __future__ import annotations

import numpy as np

from models.dh import DHTable, forward_frames

DEG = np.pi / 180.0

#: Brause Fig. 2b, standard DH. Lengths converted from the table's millimetres.
DH = DHTable(
    alpha=np.array([-90.0, 0.0, 90.0, -90.0, 90.0, 0.0]) * DEG,
    a=np.array([0.0, 0.4318, -0.02032, 0.0, 0.0, 0.0]),
    d=np.array([0.0, 0.14909, 0.0, 0.43307, 0.0, 0.05625]),
    lower=np.array([-160.0, -225.0, -45.0, -110.0, -100.0, -266.0]) * DEG,
    upper=np.array([160.0, 45.0, 225.0, 170.0, 100.0, 266.0]) * DEG,
)

#: The table's θ column, keyframe ``home``.
HOME = np.array([90.0, 0.0, 90.0, 0.0, 0.0, 0.0]) * DEG

A2, A3 = DH.a[1], DH.a[2]
D2, D4 = DH.d[1], DH.d[3]

#: Largest distance of the wrist centre from the joint-2 axis plane origin, R = |p|² - d2².
ARM_REACH = A2 + float(np.hypot(D4, A3))  # 0.8653 m


def frames(theta: np.ndarray) -> np.ndarray:
    """T_0i for i = 0..6; theta shape (..., 6) -> (..., 7, 4, 4)."""
    return forward_frames(DH, theta)


def wrist_center(theta: np.ndarray) -> np.ndarray:
    """Brause (5.6): origin of frame 4 from θ1..θ3.

    Args:
        theta: shape (..., >=3); only the first three angles are used.
    Returns:
        p, shape (..., 3), metres in frame 0.
    """
    theta = np.asarray(theta, dtype=float)
    t1, t2, t3 = theta[..., 0], theta[..., 1], theta[..., 2]
    c1, s1, c2, s2 = np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2)
    c23, s23 = np.cos(t2 + t3), np.sin(t2 + t3)
    reach = A2 * c2 + A3 * c23 + D4 * s23
    return np.stack(
        [c1 * reach - D2 * s1, s1 * reach + D2 * c1, D4 * c23 - A3 * s23 - A2 * s2], axis=-1
    )


#: Arm configurations of Brause Fig. 5c: (ARM, ELBOW).
CONFIGURATIONS = {
    "left-above": (-1, 1),
    "left-below": (-1, -1),
    "right-above": (1, 1),
    "right-below": (1, -1),
}


def wrist_ik(p: np.ndarray, arm: int, elbow: int) -> tuple[np.ndarray, np.ndarray]:
    """Brause Fig. 5c (Fu, Gonzalez & Lee pp. 63-66): θ1..θ3 that put the wrist centre at p.

    Args:
        p: wrist-centre positions in frame 0, shape (..., 3), metres.
        arm: +1 RIGHT or -1 LEFT arm; elbow: +1 ABOVE or -1 BELOW arm.
    Returns:
        theta, shape (..., 3), wrapped to [-π, π]; reachable, shape (...,) bool. Where a point is
        unreachable its angles are set to 0 (never NaN).
    """
    p = np.asarray(p, dtype=float)
    px, py, pz = p[..., 0], p[..., 1], p[..., 2]
    r2 = px**2 + py**2 - D2**2
    reachable = r2 > 0.0
    r = np.sqrt(np.maximum(r2, 0.0))
    R = np.sqrt(np.maximum(r2 + pz**2, 1e-300))
    l4 = np.hypot(D4, A3)  # elbow-to-wrist distance
    cos_beta = (A2**2 + R**2 - l4**2) / (2 * A2 * R)
    cos_phi = (A2**2 + l4**2 - R**2) / (2 * A2 * l4)
    reachable &= (np.abs(cos_beta) <= 1.0) & (np.abs(cos_phi) <= 1.0)
    cos_beta, cos_phi = np.clip(cos_beta, -1, 1), np.clip(cos_phi, -1, 1)
    sin_beta = np.sqrt(1 - cos_beta**2)
    ae = arm * elbow

    theta1 = np.arctan2(-arm * py * r - px * D2, -arm * px * r + py * D2)
    sin_a, cos_a = -pz / R, -arm * r / R
    theta2 = np.arctan2(
        sin_a * cos_beta + ae * cos_a * sin_beta, cos_a * cos_beta - ae * sin_a * sin_beta
    )
    sin_phi = ae * np.sqrt(1 - cos_phi**2)
    sin_b, cos_b = D4 / l4, abs(A3) / l4
    theta3 = np.arctan2(sin_phi * cos_b - cos_phi * sin_b, cos_phi * cos_b + sin_phi * sin_b)
    theta = np.stack([theta1, theta2, theta3], axis=-1)
    return np.where(reachable[..., None], theta, 0.0), reachable


def jacobian(theta: np.ndarray, point: int = 6) -> np.ndarray:
    """Geometric Jacobian of the origin of frame ``point`` (6 = tcp, 4 = wrist centre).

    Args:
        theta: (..., 6) joint angles.
    Returns:
        (..., 6, 6): rows 0-2 linear velocity (m/rad), rows 3-5 angular velocity, in frame 0;
        column i is joint i+1: [z_i × (p - p_i); z_i].
    """
    T = frames(theta)  # (..., 7, 4, 4)
    z = T[..., :6, :3, 2]  # (..., 6, 3) joint axes
    p = T[..., :6, :3, 3]  # (..., 6, 3) axis origins
    tip = T[..., point, None, :3, 3]  # (..., 1, 3)
    linear = np.cross(z, tip - p)
    if point < 6:
        linear[..., point:, :] = 0.0  # joints beyond the point do not move it
    return np.swapaxes(np.concatenate([linear, z], axis=-1), -1, -2)
