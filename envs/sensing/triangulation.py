"""Stereo triangulation in closed form, elementwise: the same bits for one point or a batch.

Every operation is an IEEE-754 ``+``, ``-``, ``*``, ``/`` or square root, which NumPy float64
arrays and the compiled kernel (:func:`envs.sensing.pinhole_kernels.triangulate`, the same
operations in the same order) both round correctly: the two give bit-identical points for the
same pixels, whichever the install runs (``envs.reward`` relies on this).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

Number = Any  # a Python float or a float64 array; every argument of one call broadcasts
#: One camera as plain floats: rotation columns r_x, r_y, r_z (3 × (3,)), their dot products
#: with the camera position (r_x · c, r_y · c, r_z · c) in metres, focal (f_u, f_v) in pixels per
#: normalised unit, centre (c_u, c_v) in pixels.
CameraFloats = tuple[
    tuple[tuple[float, ...], ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]
]


def camera_floats(camera) -> CameraFloats:
    """A :class:`envs.sensing.stereo.PinholeCamera` as nested tuples of floats."""
    columns = camera.rotation.T  # (3, 3) rows r_x, r_y, r_z
    return (
        tuple(map(tuple, columns.tolist())),
        tuple((columns @ camera.position).tolist()),
        tuple(camera.focal.tolist()),
        tuple(camera.center.tolist()),
    )


def camera_array(camera) -> np.ndarray:
    """:func:`camera_floats` as one row (16,) for the compiled kernels: r_x, r_y, r_z, their dot
    products with the camera position, f_u, f_v, c_u, c_v."""
    (rx, ry, rz), offsets, focal, centre = camera_floats(camera)
    return np.array([*rx, *ry, *rz, *offsets, *focal, *centre])


def triangulate_elementwise(
    cameras: Sequence[CameraFloats], q: Sequence[Number] | np.ndarray, normalized: bool = False
) -> tuple[Number, Number, Number]:
    """World point (x, y, z) in metres whose images are closest, in the least-squares sense of
    the four ray planes, to q = (u_left, v_left, u_right, v_right).

    Each camera (centre c, rotation columns r_x, r_y, r_z) and normalised image point (x, y)
    gives the planes n · p = n · c with n = r_x + x r_z and n = r_y + y r_z (n · c = r_x · c +
    x r_z · c, and likewise for y). The normal
    equations A p = g, A = Σ n nᵀ, g = Σ n (n · c), are solved by the adjugate (A is symmetric
    positive definite for two distinct cameras). Written out term by term, without loops over
    arrays, so that floats and arrays take the same operations.

    Args:
        cameras: the two cameras, from :func:`camera_floats`.
        q: four pixel coordinates (normalised coordinates if ``normalized``), floats or arrays
            of one broadcastable shape.

    Returns:
        (x, y, z), each a float or an array of the broadcast shape.
    """
    a00 = a01 = a02 = a11 = a12 = a22 = g0 = g1 = g2 = 0.0
    for k, ((rx, ry, rz), (xc, yc, zc), (fu, fv), (cu, cv)) in enumerate(cameras):
        u, v = q[2 * k], q[2 * k + 1]
        x, y = (u, v) if normalized else ((u - cu) / fu, (cv - v) / fv)
        for r, t, rc in ((rx, x, xc), (ry, y, yc)):
            n0, n1, n2 = r[0] + t * rz[0], r[1] + t * rz[1], r[2] + t * rz[2]
            offset = rc + t * zc
            a00, a01, a02 = a00 + n0 * n0, a01 + n0 * n1, a02 + n0 * n2
            a11, a12, a22 = a11 + n1 * n1, a12 + n1 * n2, a22 + n2 * n2
            g0, g1, g2 = g0 + n0 * offset, g1 + n1 * offset, g2 + n2 * offset
    return solve_normal_equations(a00, a01, a02, a11, a12, a22, g0, g1, g2)


def solve_normal_equations(
    a00: Number,
    a01: Number,
    a02: Number,
    a11: Number,
    a12: Number,
    a22: Number,
    g0: Number,
    g1: Number,
    g2: Number,
) -> tuple[Number, Number, Number]:
    """p = A⁻¹ g for the symmetric A (its upper triangle a_ij) by the adjugate, term by term
    (floats or arrays; the compiled triangulation calls this same function)."""  # fmt: skip
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    det = a00 * c00 + a01 * c01 + a02 * c02
    x = (c00 * g0 + c01 * g1 + c02 * g2) / det
    y = (c01 * g0 + c11 * g1 + c12 * g2) / det
    z = (c02 * g0 + c12 * g1 + c22 * g2) / det
    return x, y, z


def distance_elementwise(p: Sequence[Number], q: Sequence[Number]) -> Number:
    """Euclidean distance between points given as coordinate triples (floats or arrays)."""
    dx, dy, dz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
    squared = dx * dx + dy * dy + dz * dz
    return math.sqrt(squared) if isinstance(squared, float) else np.sqrt(squared)
