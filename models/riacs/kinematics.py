"""The RIACS benchmark of Jorgensen (1990), RIACS TR 90.28: arm and camera formulas.

Each function keeps the MATLAB argument order of the report's appendix and returns a tuple in the
order of its MATLAB outputs; every argument may be a numpy array (element-wise, broadcast).
Units: the report's "units", taken as metres here.
"""

from __future__ import annotations

import numpy as np

LINK1 = 0.6  #: m, link 1 (report: "arm1=.6")
LINK2 = 0.4  #: m, link 2 (report: "arm2=.4")
FOCAL_LENGTH = 1.0  #: report's camera model, build3dpts: focallength=1
HALF_SEPARATION = 0.3  #: d in camera(): half the distance between the two camera axes
ARM_REACH = LINK1 + LINK2  # 1.0 m

#: Joint ranges of build3dpts (rad): start .001, ends pi/2, pi/2 - asin(arm2/arm1), pi - pi/180.
LOWER = np.array([0.001, 0.001, 0.001])
UPPER = np.array([np.pi / 2, np.pi / 2 - np.arcsin(LINK2 / LINK1), np.pi - np.pi / 180])
HOME = (LOWER + UPPER) / 2  # mid-range keyframe ``home``


def robot3df(l1, l2, theta1, theta2, theta3):
    """Forward kinematics: joint angles -> tool point (x, y, z).

    theta1 is the base rotation (x = r sin θ1, y = r cos θ1), theta2 the elevation of link 1 and
    theta3 the interior angle between the links.
    """
    d = np.sqrt(l1**2 + l2**2 - 2 * l1 * l2 * np.cos(theta3))
    tstar = theta2 - np.arccos(np.clip((d**2 + l1**2 - l2**2) / (2 * d * l1), -1.0, 1.0))
    r = d * np.cos(tstar)
    z = d * np.sin(tstar)
    return r * np.sin(theta1), r * np.cos(theta1), z


def robot3dinv(l1, l2, x, y, z, xp=np):
    """Inverse kinematics: tool point -> (θ1, θ2, θ3), the report's single branch (elbow above the
    shoulder-tool line).

    atan(x/y) of the report is written atan2(x, y): equal for y > 0 (the report's quadrant) and
    defined at y = 0. ``xp=math`` evaluates the same formula on Python floats (one point, no
    array overhead); ``math`` raises ValueError where numpy gives NaN (no solution).
    """
    d = xp.sqrt(x * x + y * y + z * z)  # products, not powers: Python's x**2 is libm's pow
    theta3 = xp.acos((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2))
    theta2 = xp.asin(z / d) + xp.acos((d * d + l1 * l1 - l2 * l2) / (2 * d * l1))
    theta1 = xp.atan2(x, y)
    return theta1, theta2, theta3


def camera(f, d, x, y, z):
    """Projection of (x, y, z) into both cameras: (x1, y1, x2, y2), normalised by focal length f.

    Camera 1 has its pinhole at (d, 0, f), camera 2 at (-d, 0, f); both look down -z.
    """
    x1 = f * (x - d) / (f - z)
    y1 = f * y / (f - z)
    x2 = (x + d) * f / (f - z)
    y2 = f * y / (f - z)
    return x1, y1, x2, y2


def camerafd(f, d, x1, y1, x2, y2):
    """Stereo reconstruction, the inverse of :func:`camera`: (x1, y1, x2, y2) -> (x, y, z).

    y1 is not needed by the report's formula (it equals y2 for an exact projection).
    """
    del y1
    z = f - (2 * d * f) / (x2 - x1)
    x = x1 * (f - z) / f + d
    y = y2 * (f - z) / f
    return x, y, z
