"""The local fit of Ā (``learners/som/local_fit.py``) as one compiled kernel (numba).

The same formulas as the numpy reference :func:`learners.som.local_fit.local_abar`, with the
two library calls replaced by small loops that need no LAPACK call:

- the principal directions of the box: the right singular vectors of ``spread`` (K, D) by
  one-sided Jacobi rotations (Hestenes): pairs of columns are rotated until every pair is
  orthogonal; the column norms are then the singular values and the product of the rotations
  holds the right singular vectors. It works on ``spread`` itself, not on spreadᵀ·spread, so
  small singular values keep their relative accuracy, as in the reference's SVD;
- the fit: with X = (1, z) and G = diag(g), Ā = e_uᵀ (XᵀGX + ridge)⁻¹ XᵀG a_k, e_u = (1, z_u),
  is computed as Σ_k c_k A_k with c = G X y and (XᵀGX + ridge) y = e_u (a Cholesky solve of
  the (1 + m)² Gram matrix, symmetric positive definite: g > 0 and a ridge on the slopes).

The signs of the singular vectors differ from LAPACK's, which does not change Ā: a flipped
direction flips its z and z_u together, and the clamp of z_u into [min z, max z] with them.
Their order is the same (largest singular value first); results agree with the reference to
rounding (``tests/test_local_fit_kernel.py``).
"""

from __future__ import annotations

import math

import numpy as np

from learners.compiled import jit as _jit

#: Sweeps of Jacobi rotations at most (4 columns converge in about 5).
MAX_SWEEPS = 30
#: Two columns count as orthogonal when |a_p·a_q| ≤ this × |a_p| |a_q|.
ORTHOGONAL = 1e-15
_TINY = np.finfo(np.float64).tiny


@_jit
def _right_singular(a: np.ndarray, v: np.ndarray) -> None:
    """One-sided Jacobi on the columns of a (K, D), in place: afterwards the columns are
    orthogonal, their norms the singular values, and v (D, D) the right singular vectors as
    columns (unsorted)."""
    K, D = a.shape
    v[:, :] = 0.0
    for d in range(D):
        v[d, d] = 1.0
    for _ in range(MAX_SWEEPS):
        rotated = False
        for p in range(D - 1):
            for q in range(p + 1, D):
                alpha, beta, gamma = 0.0, 0.0, 0.0
                for k in range(K):
                    alpha += a[k, p] * a[k, p]
                    beta += a[k, q] * a[k, q]
                    gamma += a[k, p] * a[k, q]
                if abs(gamma) <= ORTHOGONAL * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = 1.0 / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                if zeta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(1.0 + t * t)
                s = c * t
                for k in range(K):  # a_p·a_q = 0 after the rotation
                    ap, aq = a[k, p], a[k, q]
                    a[k, p], a[k, q] = c * ap - s * aq, s * ap + c * aq
                for d in range(D):
                    vp, vq = v[d, p], v[d, q]
                    v[d, p], v[d, q] = c * vp - s * vq, s * vp + c * vq
        if not rotated:
            return


@_jit
def _cholesky_solve(gram: np.ndarray, y: np.ndarray) -> None:
    """y ← gram⁻¹ y for a symmetric positive definite gram (n, n); gram is overwritten by its
    Cholesky factor L (lower triangle)."""
    n = len(y)
    for i in range(n):
        for j in range(i + 1):
            acc = gram[i, j]
            for k in range(j):
                acc -= gram[i, k] * gram[j, k]
            gram[i, j] = math.sqrt(acc) if i == j else acc / gram[j, j]
    for i in range(n):  # L x = y
        acc = y[i]
        for k in range(i):
            acc -= gram[i, k] * y[k]
        y[i] = acc / gram[i, i]
    for i in range(n - 1, -1, -1):  # Lᵀ y = x
        acc = y[i]
        for k in range(i + 1, n):
            acc -= gram[k, i] * y[k]
        y[i] = acc / gram[i, i]


@_jit
def local_fit(
    s: int,
    u: np.ndarray,
    w: np.ndarray,
    A: np.ndarray,
    shape: np.ndarray,
    radius: int,
    sigma: float,
    ridge: float,
    out: np.ndarray,
) -> None:
    """Ā (J, D) at target u (D,) from the A_r (N, J, D) of winner s's lattice box
    |r_a − s_a| ≤ radius on a lattice of shape (n0, n1, n2), written into ``out``; A_s when
    the box holds fewer than m + 2 neurons (m = min(J, D)). ``sigma``: width of the weights
    (lattice units); ``ridge``: on the slopes (``learners/som/local_fit.py``)."""
    J, D = A.shape[1], A.shape[2]
    m = min(J, D)
    n0, n1, n2 = shape[0], shape[1], shape[2]
    c0, c1, c2 = s // (n1 * n2), s // n2 % n1, s % n2
    lo0, hi0 = max(c0 - radius, 0), min(c0 + radius + 1, n0)
    lo1, hi1 = max(c1 - radius, 0), min(c1 + radius + 1, n1)
    lo2, hi2 = max(c2 - radius, 0), min(c2 + radius + 1, n2)
    K = (hi0 - lo0) * (hi1 - lo1) * (hi2 - lo2)
    if K < m + 2:
        out[:, :] = A[s]
        return
    index, g = np.empty(K, np.int64), np.empty(K)
    k, total = 0, 0.0
    for i0 in range(lo0, hi0):  # the box in C order, weights exp(−|r − s|² / 2σ²)
        for i1 in range(lo1, hi1):
            for i2 in range(lo2, hi2):
                d2 = (i0 - c0) ** 2 + (i1 - c1) ** 2 + (i2 - c2) ** 2
                index[k] = (i0 * n1 + i1) * n2 + i2
                g[k] = math.exp(-d2 / (2.0 * sigma * sigma))
                total += g[k]
                k += 1
    centre = np.zeros(D)
    for k in range(K):
        g[k] /= total
        for d in range(D):
            centre[d] += g[k] * w[index[k], d]
    dw, spread = np.empty((K, D)), np.empty((K, D))
    for k in range(K):
        root = math.sqrt(g[k])
        for d in range(D):
            dw[k, d] = w[index[k], d] - centre[d]
            spread[k, d] = root * dw[k, d]
    v = np.empty((D, D))
    _right_singular(spread, v)
    sv = np.empty(D)
    for d in range(D):
        acc = 0.0
        for k in range(K):
            acc += spread[k, d] * spread[k, d]
        sv[d] = math.sqrt(acc)
    order = np.argsort(-sv, kind="mergesort")  # largest first
    scale = max(sv[order[0]], _TINY)
    basis = np.empty((D, m))  # the m principal directions, in units of the RMS spread
    for i in range(m):
        for d in range(D):
            basis[d, i] = v[d, order[i]] / scale
    X = np.empty((K, 1 + m))  # (1, z_k)
    e = np.empty(1 + m)  # (1, z_u), z_u clamped into the box's range
    e[0] = 1.0
    for i in range(m):
        low, high, zu = np.inf, -np.inf, 0.0
        for k in range(K):
            z = 0.0
            for d in range(D):
                z += dw[k, d] * basis[d, i]
            X[k, 0], X[k, 1 + i] = 1.0, z
            low, high = min(low, z), max(high, z)
        for d in range(D):
            zu += (u[d] - centre[d]) * basis[d, i]
        e[1 + i] = min(max(zu, low), high)
    gram = np.zeros((1 + m, 1 + m))
    for a in range(1 + m):
        for b in range(1 + m):
            for k in range(K):
                gram[a, b] += X[k, a] * (g[k] * X[k, b])
    for i in range(1, 1 + m):
        gram[i, i] += ridge
    _cholesky_solve(gram, e)  # e becomes y
    out[:, :] = 0.0
    for k in range(K):
        c = 0.0
        for i in range(1 + m):
            c += X[k, i] * e[i]
        c *= g[k]
        r = index[k]
        for j in range(J):
            for d in range(D):
                out[j, d] += c * A[r, j, d]
