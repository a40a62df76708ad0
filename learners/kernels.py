"""Compiled kernels (numba) of the Kohonen map's hot path: winner search, output averaging and
the neighbourhood update, each one loop over the neurons of the winner's box.

They compute the same formulas as the numpy reference in ``learners/som.py``, term by term:
    winner   s = argmin_r |w_r|² − 2 w_r·u
    coarse   θ0 = Σ_r g_r (θ_r + A_r (u − w_r)),  Ā = Σ_r g_r A_r,  g = h'/Σh'
    fine     θ_{k+1} = θ_k + Ā (u − v_k), Ā refined by a Broyden step
    learn    θ*, A* from the trial; w_r += ε h_r (u − w_r), |w_r|² refreshed;
             θ_r += ε' h'_r (θ* − θ_r) clipped; A_r += ε' h'_r (A* − A_r)
with h = weight[d²] from the lattice's table (0 beyond the cut-off). The elementwise updates
are the same operations in the same order, so w matches the numpy path bit for bit; the sums
over neurons are added in another order, which changes θ0 and Ā by a few units in the last
place (``tests/test_kernels.py`` bounds the difference over 1,000 trials).

numba is optional (extra ``fast``); :func:`available` says whether it imports. The winner
search lives in ``learners/winner_search.py``.
"""

from __future__ import annotations

import numpy as np

from learners.compiled import available
from learners.compiled import jit as _jit
from learners.winner_search import (
    BLOCK,
    SLACK,
    block_of,
    refresh_blocks,
    winner,
    winner_pruned,
)

__all__ = [
    "BLOCK", "available", "coarse", "fine", "learn", "refresh_blocks", "winner", "winner_pruned"
]  # fmt: skip


#: Lattices of up to this many axes (a shorter shape is padded with leading 1s).
MAX_AXES = 3
#: What :func:`learn` did.
LEARNED, NOT_FINITE, SMALL_DV = 0, 1, 2


@_jit
def _sphere(s: int, r2: int, shape: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices (K,) and squared lattice distances (K,) of the neurons within squared
    distance r2 of neuron s, in C order, on a lattice of shape (n0, n1, n2)."""
    n0, n1, n2 = shape[0], shape[1], shape[2]
    c0, c1, c2 = s // (n1 * n2), s // n2 % n1, s % n2
    reach = int(np.sqrt(r2))
    while (reach + 1) * (reach + 1) <= r2:
        reach += 1
    while reach * reach > r2:
        reach -= 1
    lo0, hi0 = max(c0 - reach, 0), min(c0 + reach + 1, n0)
    lo1, hi1 = max(c1 - reach, 0), min(c1 + reach + 1, n1)
    lo2, hi2 = max(c2 - reach, 0), min(c2 + reach + 1, n2)
    count = (hi0 - lo0) * (hi1 - lo1) * (hi2 - lo2)
    index, dist2 = np.empty(count, np.int64), np.empty(count, np.int64)
    k = 0
    for i in range(lo0, hi0):
        di = (i - c0) * (i - c0)
        for j in range(lo1, hi1):
            dij = di + (j - c1) * (j - c1)
            if dij > r2:
                continue
            base = (i * n1 + j) * n2
            for m in range(lo2, hi2):
                d2 = dij + (m - c2) * (m - c2)
                if d2 <= r2:
                    index[k], dist2[k] = base + m, d2
                    k += 1
    return index[:k], dist2[:k]


@_jit
def coarse(
    s: int,
    u: np.ndarray,
    w: np.ndarray,
    w2: np.ndarray,
    theta: np.ndarray,
    A: np.ndarray,
    table: np.ndarray,
    r2: int,
    shape: np.ndarray,
) -> tuple[int, np.ndarray, np.ndarray]:
    """Winner s (s < 0: search it), averaged output θ0 (J,) and Ā (J, D) with weights
    table[d²] around s (the winner alone for r2 = 0)."""
    if s < 0:
        s = winner(w, w2, u)
    J, D = A.shape[1], A.shape[2]
    out, abar = np.zeros(J), np.zeros((J, D))
    if r2 == 0:
        for j in range(J):
            acc = 0.0
            for d in range(D):
                acc += A[s, j, d] * (u[d] - w[s, d])
                abar[j, d] = A[s, j, d]
            out[j] = theta[s, j] + acc
        return s, out, abar
    index, dist2 = _sphere(s, r2, shape)
    total = 0.0
    du = np.empty(D)
    for k in range(len(index)):  # Σ g_r (θ_r + A_r (u − w_r)) and Σ g_r A_r, then / Σ g_r
        r, g = index[k], table[dist2[k]]
        total += g
        for d in range(D):
            du[d] = u[d] - w[r, d]
        for j in range(J):
            acc = theta[r, j]
            for d in range(D):
                acc += A[r, j, d] * du[d]
                abar[j, d] += g * A[r, j, d]
            out[j] += g * acc
    return s, out / total, abar / total


@_jit
def fine(
    u: np.ndarray,
    v: np.ndarray,
    cmd: np.ndarray,
    abar: np.ndarray,
    v_before: np.ndarray,
    cmd_before: np.ndarray,
    refine: bool,
    min_dv: float,
    noise: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> np.ndarray:
    """Next fine command clip(θ_k + Ā (u − v_k) + noise) (J,); with ``refine`` Ā first takes
    the Broyden step Ā += (Δθ − Ā Δv) Δv^T / |Δv|² of the previous fine move, in place, when
    |Δv| ≥ min_dv (Δθ = cmd − cmd_before, Δv = v − v_before)."""
    J, D = abar.shape
    if refine:
        dv = v - v_before
        dv2 = 0.0
        for d in range(D):
            dv2 += dv[d] * dv[d]
        if dv2 >= min_dv * min_dv:
            for j in range(J):
                res = 0.0
                for d in range(D):
                    res += abar[j, d] * dv[d]
                res = (cmd[j] - cmd_before[j]) - res
                for d in range(D):
                    abar[j, d] += res * (dv[d] / dv2)
    out = np.empty(J)
    for j in range(J):
        acc = 0.0
        for d in range(D):
            acc += abar[j, d] * (u[d] - v[d])
        out[j] = min(max(cmd[j] + acc + noise[j], lower[j]), upper[j])
    return out


@_jit
def learn(
    s: int,
    mrs: bool,
    u: np.ndarray,
    theta0: np.ndarray,
    v0: np.ndarray,
    theta1: np.ndarray,
    v1: np.ndarray,
    min_dv: float,
    w: np.ndarray,
    w2: np.ndarray,
    theta: np.ndarray,
    A: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    eps: float,
    table_w: np.ndarray,
    eps_out: float,
    table_out: np.ndarray,
    shape: np.ndarray,
    block_centre: np.ndarray,
    block_radius: np.ndarray,
) -> int:
    """One trial's learning step in place around winner s (s < 0: search it), from the targets
    θ* ("mrs": θ_s + A_s(u − v0), else θ1 + A_s(w_s − v1)) and A* = A_s + (Δθ − A_s Δv)Δv^T/|Δv|²,
    both taken before the update;
    h = table_w[d²], h' = table_out[d²] (``Lattice.weights``: cut-off r² = len − 2).

    With blocks (``block_radius`` not empty, see :func:`refresh_blocks`), each moved w_r
    widens its block's radius to cover it (the centre stays), so the bounds stay valid.

    Returns LEARNED, or, with nothing changed, NOT_FINITE (an input holds NaN/inf) or SMALL_DV
    (|v1 − v0| < min_dv)."""
    J, D = A.shape[1], A.shape[2]
    check = 0.0
    for d in range(D):
        check += u[d] * 0.0 + v0[d] * 0.0 + v1[d] * 0.0
    for j in range(J):
        check += theta0[j] * 0.0 + theta1[j] * 0.0
    if check != 0.0:  # x · 0 is NaN exactly for NaN and ±inf
        return NOT_FINITE
    dv = v1 - v0
    dv2 = 0.0
    for d in range(D):
        dv2 += dv[d] * dv[d]
    if dv2 < min_dv * min_dv:
        return SMALL_DV
    if s < 0:
        s = winner(w, w2, u)
    theta_star, a_star = np.empty(J), np.empty((J, D))
    for j in range(J):
        lin, res = 0.0, 0.0
        for d in range(D):
            lin += A[s, j, d] * (u[d] - v0[d] if mrs else w[s, d] - v1[d])
            res += A[s, j, d] * dv[d]
        theta_star[j] = (theta[s, j] if mrs else theta1[j]) + lin
        res = (theta1[j] - theta0[j]) - res
        for d in range(D):
            a_star[j, d] = A[s, j, d] + res * (dv[d] / dv2)
    index, dist2 = _sphere(s, len(table_w) - 2, shape)
    for k in range(len(index)):
        r, e = index[k], eps * table_w[dist2[k]]
        sq = 0.0
        for d in range(D):
            w[r, d] += e * (u[d] - w[r, d])
            sq += w[r, d] * w[r, d]
        w2[r] = sq
        if len(block_radius) > 0:
            b = block_of(r, shape)
            far = 0.0
            for d in range(D):
                far += (w[r, d] - block_centre[b, d]) ** 2
            block_radius[b] = max(block_radius[b], np.sqrt(far) * (1.0 + SLACK) + SLACK)
    index, dist2 = _sphere(s, len(table_out) - 2, shape)
    for k in range(len(index)):
        r, e = index[k], eps_out * table_out[dist2[k]]
        for j in range(J):
            x = theta[r, j] + e * (theta_star[j] - theta[r, j])
            theta[r, j] = min(max(x, lower[j]), upper[j])
            for d in range(D):
                A[r, j, d] += e * (a_star[j, d] - A[r, j, d])
    return LEARNED
