"""Stereo triangulation in closed form, elementwise: the same bits for one point or a batch.

Every operation is an IEEE-754 ``+``, ``-``, ``*``, ``/`` or square root, which Python floats and
NumPy float64 arrays both round correctly. One call on Python floats (a single point, a few
microseconds) and one on arrays of any shape (a batch) therefore give bit-identical results for
the same pixels: the reach reward relies on this (``envs.reward``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

Number = Any  # a Python float or a float64 array; every argument of one call broadcasts
#: One camera as plain floats: position (3,), rotation columns x, y, z (3 × (3,)), focal (f_u,
#: f_v) in pixels per normalised unit, centre (c_u, c_v) in pixels.
CameraFloats = tuple[list[float], list[list[float]], list[float], list[float]]


def camera_floats(camera) -> CameraFloats:
    """A :class:`envs.stereo.PinholeCamera` as nested lists of floats (read at every call, so a
    camera changed at run time is used as it is)."""
    return (
        camera.position.tolist(),
        camera.rotation.T.tolist(),
        camera.focal.tolist(),
        camera.center.tolist(),
    )


def _planes(camera: CameraFloats, u: Number, v: Number, normalized: bool):
    """The two planes through the camera centre that contain the ray of pixel (u, v): normals
    r_x + x r_z and r_y + y r_z, and offsets normal · c."""
    (c, (rx, ry, rz), (fu, fv), (cu, cv)) = camera
    x, y = (u, v) if normalized else ((u - cu) / fu, (cv - v) / fv)
    planes = []
    for r, t in ((rx, x), (ry, y)):
        n = (r[0] + t * rz[0], r[1] + t * rz[1], r[2] + t * rz[2])
        planes.append((n, n[0] * c[0] + n[1] * c[1] + n[2] * c[2]))
    return planes


def triangulate_elementwise(
    cameras: Sequence[CameraFloats], q: Sequence[Number], normalized: bool = False
) -> tuple[Number, Number, Number]:
    """World point (x, y, z) in metres whose images are closest, in the least-squares sense of
    the four ray planes, to q = (u_left, v_left, u_right, v_right).

    Args:
        cameras: the two cameras, from :func:`camera_floats`.
        q: four pixel coordinates (normalised coordinates if ``normalized``), floats or arrays
            of one broadcastable shape.

    Returns:
        (x, y, z), each a float or an array of the broadcast shape. The 3×3 normal equations
        A p = g are solved by the adjugate (A is symmetric positive definite for two distinct
        cameras).
    """
    planes = [*_planes(cameras[0], q[0], q[1], normalized)]
    planes += _planes(cameras[1], q[2], q[3], normalized)
    a = [[0.0] * 3 for _ in range(3)]
    g = [0.0] * 3
    for n, offset in planes:
        for i in range(3):
            g[i] = g[i] + n[i] * offset
            for j in range(i, 3):
                a[i][j] = a[i][j] + n[i] * n[j]
    (a00, a01, a02), (_, a11, a12), (_, _, a22) = a
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    det = a00 * c00 + a01 * c01 + a02 * c02
    x = (c00 * g[0] + c01 * g[1] + c02 * g[2]) / det
    y = (c01 * g[0] + c11 * g[1] + c12 * g[2]) / det
    z = (c02 * g[0] + c12 * g[1] + c22 * g[2]) / det
    return x, y, z


def distance_elementwise(p: Sequence[Number], q: Sequence[Number]) -> Number:
    """Euclidean distance between points given as coordinate triples (floats or arrays)."""
    dx, dy, dz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
    squared = dx * dx + dy * dy + dz * dz
    return math.sqrt(squared) if isinstance(squared, float) else np.sqrt(squared)
