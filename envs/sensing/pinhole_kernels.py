"""Compiled kernels (numba, extra ``fast``) of the env's per-transition arithmetic: the exact
pinhole projection of points into both cameras with each camera's visibility test (project
sensing), and the distance between the triangulated points of two stereo goals (the reach
reward).

Each computes its numpy reference operation for operation, so the results are the same bits:
    sight           :func:`envs.sensing.sensors.sight` (numpy path)
    triangulate     :func:`envs.sensing.triangulation.triangulate_elementwise`
    goal_distances  :func:`envs.reward.goal_distances` (numpy path)
``tests/test_pinhole_kernels.py`` compares them. ``ENABLED`` says whether the env calls them
(numba imports); tests switch it off to run the numpy paths.

The kernels write into arrays they are given and return nothing or numbers: an array made in a
kernel is returned through a Python call inside numba's dispatcher, where a Ctrl-C arriving then
would be raised and lost (numba reports a SystemError instead of the KeyboardInterrupt).
"""

from __future__ import annotations

import math

import numpy as np

from envs.sensing.triangulation import solve_normal_equations
from learners.compiled import available, jit

#: Whether project sensing and the reach reward call these kernels instead of their numpy paths.
ENABLED = available()
#: The numpy path's solve of the normal equations, compiled: one formula for both paths.
_solve = jit(solve_normal_equations)


@jit
def sight(
    projection: np.ndarray,
    xpos: np.ndarray,
    ids: np.ndarray,
    u_max: float,
    v_max: float,
    pixels: np.ndarray,
    visible: np.ndarray,
) -> None:
    """Fills ``pixels`` (4M,) [u1, v1, u2, v2 per point] and ``visible`` (2M,) per point and
    camera for the world points ``xpos[ids]`` (M, 3) m: ``projection`` (4, 6) maps [p, 1] to
    (d1 u1, d1 v1, d1, d2 u2, d2 v2, d2); a camera sees a point in front of it (d > 0) whose
    image lies in [0, u_max] × [0, v_max], and its pixels are NaN where it does not."""
    for m in range(len(ids)):
        x, y, z = xpos[ids[m], 0], xpos[ids[m], 1], xpos[ids[m], 2]
        for k in range(2):
            c = 3 * k  # the camera's columns: d u, d v, d
            du = projection[0, c] * x + projection[1, c] * y + projection[2, c] * z
            dv = projection[0, c + 1] * x + projection[1, c + 1] * y + projection[2, c + 1] * z
            d = projection[0, c + 2] * x + projection[1, c + 2] * y + projection[2, c + 2] * z
            du, dv, d = du + projection[3, c], dv + projection[3, c + 1], d + projection[3, c + 2]
            u = v = np.nan
            seen = False
            if d > 0.0:
                u, v = du / d, dv / d
                seen = 0.0 <= u <= u_max and 0.0 <= v <= v_max
            visible[2 * m + k] = seen
            pixels[4 * m + 2 * k] = u if seen else np.nan
            pixels[4 * m + 2 * k + 1] = v if seen else np.nan


@jit
def _triangulate(
    cameras: np.ndarray, q: np.ndarray, j: int, normalized: bool
) -> tuple[float, float, float]:
    """:func:`envs.sensing.triangulation.triangulate_elementwise` of the goal ``q[:, j]`` (4,)
    px (normalised coordinates if ``normalized``), the cameras as rows of
    :func:`envs.sensing.triangulation.camera_array`."""
    a00 = a01 = a02 = a11 = a12 = a22 = g0 = g1 = g2 = 0.0
    for k in range(2):
        c = cameras[k]
        x, y = q[2 * k, j], q[2 * k + 1, j]
        if not normalized:
            x, y = (x - c[14]) / c[12], (c[15] - y) / c[13]
        for r in range(2):  # the planes of r_x (t = x) and of r_y (t = y)
            t = x if r == 0 else y
            n0 = c[3 * r] + t * c[6]
            n1 = c[3 * r + 1] + t * c[7]
            n2 = c[3 * r + 2] + t * c[8]
            offset = c[9 + r] + t * c[11]
            a00, a01, a02 = a00 + n0 * n0, a01 + n0 * n1, a02 + n0 * n2
            a11, a12, a22 = a11 + n1 * n1, a12 + n1 * n2, a22 + n2 * n2
            g0, g1, g2 = g0 + n0 * offset, g1 + n1 * offset, g2 + n2 * offset
    return _solve(a00, a01, a02, a11, a12, a22, g0, g1, g2)


@jit
def triangulate(cameras: np.ndarray, q: np.ndarray, normalized: bool, out: np.ndarray) -> None:
    """Fills ``out`` (N, 3) m with the world points of the goals ``q`` (4, N) px (normalised
    coordinates if ``normalized``); ``cameras`` (2, 16) as
    :func:`envs.sensing.triangulation.camera_array` lays them out."""
    for j in range(out.shape[0]):
        out[j, 0], out[j, 1], out[j, 2] = _triangulate(cameras, q, j, normalized)


@jit
def goal_distances(
    cameras: np.ndarray, achieved: np.ndarray, desired: np.ndarray, out: np.ndarray
) -> None:
    """Fills ``out`` (N,) m with the distances between the triangulated points of the goals
    ``achieved`` and ``desired`` (4, N) px; ``cameras`` (2, 16) as
    :func:`envs.sensing.triangulation.camera_array` lays them out."""
    for j in range(len(out)):
        p = _triangulate(cameras, achieved, j, False)
        q = _triangulate(cameras, desired, j, False)
        dx, dy, dz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
        out[j] = math.sqrt(dx * dx + dy * dy + dz * dz)
