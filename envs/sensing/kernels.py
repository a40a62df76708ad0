"""Compiled kernels (numba, extra ``fast``) of rendered sensing's per-pixel and per-point loops:
the sphere's own outline edges in a view, and the Gauss-Newton fit of its centre to them.

They compute the formulas of the numpy reference paths, which the base install uses and
``tests/test_sensing_kernels.py`` compares them with:
    edges     :func:`envs.sensing.marker_detection.outline_edges`, the same points in the same order
    fit       :func:`envs.sensing.marker_fit.fit_centre` (normal equations summed point by point,
              solved by Gaussian elimination with partial pivoting instead of LAPACK)
    residual  :func:`envs.sensing.marker_fit.outline_residual_px`
The edges are bit for bit the numpy path's; the fit and residuals differ by rounding (sums in
another order). ``ENABLED`` says whether the sensing uses them (numba imports); tests switch
it off to run the numpy path.
"""

from __future__ import annotations

import numpy as np

from learners.compiled import available, jit

#: Whether the marker detection and fit (envs.sensing) call these kernels instead of their numpy
#: paths.
ENABLED = available()


@jit
def outline_edges(mask: np.ndarray, depth: np.ndarray, margin: float) -> np.ndarray:
    """:func:`envs.sensing.marker_detection.outline_edges` of a blob ``mask`` (h, w) bool and
    ``depth`` (h, w) m: points (m, 2) (column, row), vertical neighbour pairs first, each in
    row-major order."""
    h, w = mask.shape
    out = np.empty(((h - 1) * w + h * (w - 1), 2))
    n = 0
    for i in range(h - 1):  # (i, j) above (i + 1, j)
        for j in range(w):
            a, b = mask[i, j], mask[i + 1, j]
            if (a and not b and depth[i + 1, j] > depth[i, j] + margin) or (
                b and not a and depth[i, j] > depth[i + 1, j] + margin
            ):
                out[n, 0], out[n, 1] = j, i + 0.5
                n += 1
    for i in range(h):  # (i, j) left of (i, j + 1)
        for j in range(w - 1):
            a, b = mask[i, j], mask[i, j + 1]
            if (a and not b and depth[i, j + 1] > depth[i, j] + margin) or (
                b and not a and depth[i, j] > depth[i, j + 1] + margin
            ):
                out[n, 0], out[n, 1] = j + 0.5, i
                n += 1
    return out[:n].copy()


@jit
def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """a · b of two vectors (numba's ``@`` needs SciPy's BLAS)."""
    total = 0.0
    for i in range(len(a)):
        total += a[i] * b[i]
    return total


@jit
def _project(projection: np.ndarray, x: float, y: float, z: float) -> tuple[float, float]:
    """Pixel (u, v) of the world point (x, y, z) m under ``projection`` (3, 4)."""
    P = projection
    h0 = P[0, 0] * x + P[0, 1] * y + P[0, 2] * z + P[0, 3]
    h1 = P[1, 0] * x + P[1, 1] * y + P[1, 2] * z + P[1, 3]
    h2 = P[2, 0] * x + P[2, 1] * y + P[2, 2] * z + P[2, 3]
    return h0 / h2, h1 / h2


@jit
def _solve(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, bool]:
    """x with a x = b for a small square ``a`` (n, n), by Gaussian elimination with partial
    pivoting; False if a pivot is exactly zero (singular, as numpy.linalg.solve would raise)."""
    n = len(b)
    a, b = a.copy(), b.copy()
    for c in range(n):
        p = c + np.argmax(np.abs(a[c:, c]))
        if a[p, c] == 0.0:
            return b, False
        if p != c:
            for k in range(n):
                a[c, k], a[p, k] = a[p, k], a[c, k]
            b[c], b[p] = b[p], b[c]
        for r in range(c + 1, n):
            f = a[r, c] / a[c, c]
            a[r, c:] -= f * a[c, c:]
            b[r] -= f * b[c]
    x = np.empty(n)
    for c in range(n - 1, -1, -1):
        x[c] = (b[c] - _dot(a[c, c + 1 :], x[c + 1 :])) / a[c, c]
    return x, True


@jit
def fit_centre(
    centres: np.ndarray,
    directions: np.ndarray,
    start: np.ndarray,
    free: int,
    max_iterations: int,
    converged_step: float,
) -> tuple[np.ndarray, bool]:
    """The Gauss-Newton loop of :func:`envs.sensing.marker_fit.fit_centre`: x = (C, R) (4,) from
    ``start`` (4,), each ray's camera centre (m, 3) and unit direction (m, 3), the first
    ``free`` of x fitted. False if the normal equations were singular (x as far as it got)."""
    x = start.copy()
    m = len(directions)
    jac = np.empty(4)
    for _ in range(max_iterations):
        jtj = np.zeros((free, free))
        jtr = np.zeros(free)
        for i in range(m):
            v0, v1, v2 = x[0] - centres[i, 0], x[1] - centres[i, 1], x[2] - centres[i, 2]
            tangent = np.sqrt(max(v0 * v0 + v1 * v1 + v2 * v2 - x[3] ** 2, 1e-12))
            d0, d1, d2 = directions[i, 0], directions[i, 1], directions[i, 2]
            r = d0 * v0 + d1 * v1 + d2 * v2 - tangent
            jac[0], jac[1], jac[2] = d0 - v0 / tangent, d1 - v1 / tangent, d2 - v2 / tangent
            jac[3] = x[3] / tangent
            for a in range(free):
                jtr[a] += jac[a] * r
                for b in range(free):
                    jtj[a, b] += jac[a] * jac[b]
        step, ok = _solve(jtj, -jtr)
        if not ok:
            return x, False
        x[:free] += step
        if _dot(step, step) < converged_step**2:
            break
    return x, True


@jit
def outline_residual_px(
    projection: np.ndarray,
    position: np.ndarray,
    centre: np.ndarray,
    radius: float,
    uv: np.ndarray,
    d: np.ndarray,
) -> np.ndarray:
    """:func:`envs.sensing.marker_fit.outline_residual_px` for a camera at ``position`` (3,) m with
    the pixel projection ``projection`` (3, 4): distance (m,) px of each point uv (m, 2) with ray
    d (m, 3) to the outline of the sphere (``centre`` (3,) m, ``radius`` m)."""
    axis = centre - position
    dist = np.sqrt(_dot(axis, axis))
    axis = axis / dist
    alpha = np.arcsin(min(radius / dist, 1.0))
    ca, sa = np.cos(alpha), np.sin(alpha)
    cu, cv = _project(projection, centre[0], centre[1], centre[2])
    out = np.empty(len(uv))
    for i in range(len(uv)):  # per point in floats: no array per point
        along = _dot(d[i], axis)
        a0, a1, a2 = d[i, 0] - along * axis[0], d[i, 1] - along * axis[1], d[i, 2] - along * axis[2]
        scale = sa / max(np.sqrt(a0 * a0 + a1 * a1 + a2 * a2), 1e-12)
        eu, ev = _project(
            projection,
            position[0] + ca * axis[0] + scale * a0,
            position[1] + ca * axis[1] + scale * a1,
            position[2] + ca * axis[2] + scale * a2,
        )
        ou, ov = eu - cu, ev - cv
        norm = max(np.sqrt(ou * ou + ov * ov), 1e-12)
        out[i] = ((uv[i, 0] - eu) * ou + (uv[i, 1] - ev) * ov) / norm
    return out
