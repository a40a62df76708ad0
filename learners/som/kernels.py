"""Compiled kernels (numba) of the Kohonen map's hot path: winner search, output averaging and
the neighbourhood update, each one loop over the neurons of the winner's box.

Each is the compiled form of a plain numpy function, term by term: :func:`learn` of
``update_rule.targets`` followed by ``update_rule.mrs_update`` (``tests/test_update_rule.py``
checks them against each other), :func:`coarse` of ``VisuomotorSOM.coarse_output``, :func:`fine`
of the fine move of ``protocols.MRS``:
    winner   s = argmin_r |w_r|² − 2 w_r·u
    coarse   θ0 = Σ_r g_r (θ_r + A_r (u − w_r)),  Ā = Σ_r g_r A_r,  g = h'/Σh'
    fine     θ_{k+1} = θ_k + Ā (u − v_k), Ā refined by a Broyden step
    learn    θ*, A* from the trial; w_r += ε h_r (u − w_r), |w_r|² refreshed;
             θ_r += ε' h'_r (θ* − θ_r) clipped; A_r += ε' h'_r (A* − A_r)
with h = weight[d²] from the lattice's table (0 beyond the cut-off). The elementwise updates
are the same operations in the same order, so w matches the numpy path bit for bit; the sums
over neurons are added in another order, which changes θ0 and Ā by a few units in the last
place (``tests/test_kernels.py`` bounds the difference over 1,000 trials).

:func:`act_coarse` and :func:`learn` first test their inputs with :func:`status` (finite, and
inside the input box and joint ranges: the tests of ``learners/guards.py``) and return a status
with nothing changed when one fails; ``learners/som/compiled_path.py`` then hands the call to the
checked path, which raises the error. numba is optional (extra ``fast``); :func:`available`
says whether it imports. The winner search lives in ``learners/som/winner_search.py``, the
local fit of Ā for the evaluation's fine moves in ``learners/som/local_fit_kernel.py``.
"""

from __future__ import annotations

import numpy as np

from learners.compiled import available
from learners.compiled import jit as _jit
from learners.som.local_fit_kernel import local_fit
from learners.som.winner_search import (
    BLOCK,
    SLACK,
    block_of,
    refresh_blocks,
    winner,
    winner_pruned,
)

__all__ = [
    "BLOCK", "act_coarse", "available", "coarse", "fine", "learn", "local_fit", "refresh_blocks",
    "status", "winner", "winner_pruned",
]  # fmt: skip


#: Lattices of up to this many axes (a shorter shape is padded with leading 1s).
MAX_AXES = 3
#: What the checks of the inputs found (:func:`status`), and what :func:`learn` did.
OK, NOT_FINITE, OUTSIDE = 0, 1, 2
LEARNED, SMALL_DV = OK, 3


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
def status(x: np.ndarray, box: np.ndarray) -> int:
    """OK, NOT_FINITE (NaN or ±inf anywhere in x) or OUTSIDE (finite, and a component beyond
    the box): |x − centre| · inv_half ≤ 1 per component, box = (centre, inv_half) (2, n), the
    same test as ``guards.InputBox.inside``."""
    outside = False
    for i in range(len(x)):
        if not np.isfinite(x[i]):
            return NOT_FINITE
        if not abs(x[i] - box[0, i]) * box[1, i] <= 1.0:
            outside = True
    return OUTSIDE if outside else OK


@_jit
def coarse(
    s: int,
    u: np.ndarray,
    w: np.ndarray,
    theta: np.ndarray,
    A: np.ndarray,
    table: np.ndarray,
    r2: int,
    shape: np.ndarray,
    out: np.ndarray,
    abar: np.ndarray,
) -> None:
    """Around winner s, the averaged output θ0 (J,) written into ``out`` and Ā (J, D) into
    ``abar``, with weights table[d²] (the winner alone for r2 = 0)."""
    J, D = A.shape[1], A.shape[2]
    if r2 == 0:
        for j in range(J):
            acc = 0.0
            for d in range(D):
                acc += A[s, j, d] * (u[d] - w[s, d])
                abar[j, d] = A[s, j, d]
            out[j] = theta[s, j] + acc
        return
    out[:] = 0.0
    abar[:] = 0.0
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
    for j in range(J):
        out[j] /= total
        for d in range(D):
            abar[j, d] /= total


@_jit
def act_coarse(
    u: np.ndarray,
    box: np.ndarray,
    w: np.ndarray,
    w2: np.ndarray,
    theta: np.ndarray,
    A: np.ndarray,
    table: np.ndarray,
    r2: int,
    shape: np.ndarray,
    joints: np.ndarray,
    block_centre: np.ndarray,
    block_radius: np.ndarray,
    out_u: np.ndarray,
    out_cmd: np.ndarray,
    out_abar: np.ndarray,
) -> int:
    """The coarse move of ``act``: u checked against the input box ``box`` (2, D); the winner
    (pruned search when there are blocks); the clipped command (J,) into ``out_cmd``, Ā into
    ``out_abar`` and u into ``out_u``. Returns the winner, or −NOT_FINITE / −OUTSIDE with
    nothing written. ``joints`` (2+, J): lower and upper joint limits in its first two rows."""
    bad = status(u, box)
    if bad != OK:
        return -bad
    if len(block_radius) > 0:
        s = winner_pruned(w, w2, u, shape, block_centre, block_radius)
    else:
        s = winner(w, w2, u)
    coarse(s, u, w, theta, A, table, r2, shape, out_cmd, out_abar)
    for j in range(len(out_cmd)):
        out_cmd[j] = min(max(out_cmd[j], joints[0, j]), joints[1, j])
    out_u[:] = u
    return s


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
    joints: np.ndarray,
) -> None:
    """The next fine command clip(θ_k + Ā (u − v_k) + noise), in place: ``cmd`` (J,) becomes
    it, ``cmd_before`` the previous command and ``v_before`` v. With ``refine`` Ā (J, D) first
    takes the Broyden step Ā += (Δθ − Ā Δv) Δv^T / |Δv|² of the previous fine move, in place,
    when |Δv| ≥ min_dv (Δθ = cmd − cmd_before, Δv = v − v_before). ``joints`` as in
    :func:`act_coarse`; u and v are checked by the caller (:func:`status`)."""
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
    for j in range(J):
        acc = 0.0
        for d in range(D):
            acc += abar[j, d] * (u[d] - v[d])
        cmd_before[j] = cmd[j]
        cmd[j] = min(max(cmd[j] + acc + noise[j], joints[0, j]), joints[1, j])
    v_before[:] = v


@_jit
def _trial_status(
    u: np.ndarray, theta0: np.ndarray, v0: np.ndarray, theta1: np.ndarray, v1: np.ndarray,
    box: np.ndarray, joints: np.ndarray,
) -> int:  # fmt: skip
    """OUTSIDE if a finite one of the trial's arrays lies outside its box (input box ``box``,
    joint box = rows 2 and 3 of ``joints``), else NOT_FINITE if one holds NaN/inf, else OK."""
    found = max(status(u, box), status(v0, box), status(v1, box))  # OUTSIDE > NOT_FINITE > OK
    return max(found, status(theta0, joints[2:]), status(theta1, joints[2:]))


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
    noise_term: float,
    w: np.ndarray,
    w2: np.ndarray,
    theta: np.ndarray,
    A: np.ndarray,
    box: np.ndarray,
    joints: np.ndarray,
    eps: float,
    table_w: np.ndarray,
    eps_out: float,
    table_out: np.ndarray,
    shape: np.ndarray,
    block_centre: np.ndarray,
    block_radius: np.ndarray,
) -> int:
    """One trial's learning step in place around winner s (s < 0: search it): the compiled form
    of ``update_rule.targets`` and ``update_rule.mrs_update``, from the targets θ* (``mrs``,
    "coarse-error": θ_s + A_s(u − v0), else "fine-error": θ1 + A_s(w_s − v1)) and
    A* = A_s + (Δθ − A_s Δv)Δv^T/|Δv|² (+ ``noise_term`` A_s / |Δv|² when it is > 0,
    ``sensing_noise``), both taken before the update;
    h = table_w[d²], h' = table_out[d²] (``Lattice.weights``: cut-off r² = len − 2).

    The inputs are checked first: u, v0, v1 against the input box ``box`` (2, D), θ0, θ1
    against the joint box, rows 2-3 of ``joints`` (4, J) = (lower, upper, centre, inv_half).
    With blocks (``block_radius`` not empty, see :func:`refresh_blocks`) the winner search is
    the pruned one, and each moved w_r widens its block's radius to cover it (the centre
    stays), so the bounds stay valid.

    Returns LEARNED, or, with nothing changed, OUTSIDE (a finite input far outside its box),
    NOT_FINITE (an input holds NaN/inf) or SMALL_DV (|v1 − v0| < min_dv)."""
    J, D = A.shape[1], A.shape[2]
    found = _trial_status(u, theta0, v0, theta1, v1, box, joints)
    if found != OK:
        return found
    dv = v1 - v0
    dv2 = 0.0
    for d in range(D):
        dv2 += dv[d] * dv[d]
    if dv2 < min_dv * min_dv:
        return SMALL_DV
    if s < 0 and len(block_radius) > 0:
        s = winner_pruned(w, w2, u, shape, block_centre, block_radius)
    elif s < 0:
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
            if noise_term > 0:
                a_star[j, d] += (noise_term / dv2) * A[s, j, d]
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
            theta[r, j] = min(max(x, joints[0, j]), joints[1, j])
            for d in range(D):
                A[r, j, d] += e * (a_star[j, d] - A[r, j, d])
    return LEARNED
