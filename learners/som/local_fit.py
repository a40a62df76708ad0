"""Ā for the fine moves from a local linear fit of the neighbours' A_r (this project's; not in
the papers).

MRS move the arm finely with Ā = Σ_r g_r A_r / Σ_r g_r, the A_r averaged over the winner's
lattice neighbourhood of width σ'. Late in training σ' is so small that Ā is the winner's A_s
alone: an estimate of the inverse Jacobian ∂θ/∂u fitted to the secants of moves anywhere in
the winner's cell, at the place w_s, not at the target u, so part of the remaining error of
a fine move is the change of the Jacobian between w_s and u (``docs/decisions.md``).

Here Ā is the value at u of a linear field fitted to the A_r of the winner's lattice box
(|r_a − s_a| ≤ ``radius``): A_r ≈ B_0 + Σ_i B_i z_i(w_r), weights exp(−|r − s|²/2) (lattice
units), z the coordinates of w_r − c (c the weighted centre of the box's w_r) along the
box's m = min(J, D) principal directions in input space, in units of the box's RMS spread.
The w_r lie near an m-dimensional surface (the arm's J joints seen in D pixels), so a fit in
all D input directions would be ill-posed across it; the principal directions are the
surface's tangent plane. u's coordinates are clamped into the box's range along each
direction (a target beyond the box's neurons gets the value at the box's edge, no
extrapolation), and a small ridge keeps the slopes finite where the box is flat. The fit
averages out part of each A_r's noise and follows the change of A across the box.

The result depends only on the map (w, A, the lattice), never on the arm's kinematics or
the cameras. This numpy function is the reference; the compiled path computes the same fit
in ``learners/som/local_fit_kernel.py``.
"""

from __future__ import annotations

import numpy as np

from learners.som.lattice import Lattice

#: Lattice radius (per axis) of the box whose A_r are fitted: 3³ = 27 neurons inside a 3-axis
#: lattice (chosen on held-out targets of another seed: radius 2 was as good, at 5× the cost).
FIT_RADIUS = 1
#: Width of the fit's weights, lattice units.
FIT_SIGMA = 1.0
#: Ridge on the slopes, relative to the box's weighted variance along its main direction.
FIT_RIDGE = 1e-3


def local_abar(grid: Lattice, s: int, u: np.ndarray, w: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Ā (J, D) at target u (D,) from the A_r of winner s's lattice box (see module notes).

    Args:
        grid: the map's lattice; s: the winner of u.
        w: (N, D) neuron positions in input space; A: (N, J, D) their local linear maps.
    Returns:
        a new (J, D) array; A_s itself when the box holds too few neurons to fit a slope.
    """
    _, J, D = A.shape
    box = grid.box(s, FIT_RADIUS * FIT_RADIUS)
    coords = grid.view(grid.coords, box).reshape(-1, len(grid.shape))
    m = min(J, D)
    if len(coords) < m + 2:
        return A[s].copy()
    d2 = ((coords - grid.coords[s]) ** 2).sum(1)
    g = np.exp(-d2 / (2.0 * FIT_SIGMA * FIT_SIGMA))  # (K,)
    g /= g.sum()
    w_k = grid.view(w, box).reshape(-1, D)  # (K, D)
    a_k = grid.view(A, box).reshape(-1, J * D)  # (K, J·D)
    centre = g @ w_k
    spread = np.sqrt(g)[:, None] * (w_k - centre)
    _, sv, vt = np.linalg.svd(spread, full_matrices=False)
    scale = max(float(sv[0]), np.finfo(float).tiny)
    basis = vt[:m].T / scale  # (D, m)
    z = (w_k - centre) @ basis  # (K, m)
    z_u = np.clip((u - centre) @ basis, z.min(0), z.max(0))  # (m,)
    X = np.hstack((np.ones((len(z), 1)), z))  # (K, 1 + m)
    gram = X.T @ (g[:, None] * X)
    gram[1:, 1:] += FIT_RIDGE * np.eye(m)
    beta = np.linalg.solve(gram, X.T @ (g[:, None] * a_k))  # (1 + m, J·D)
    return (beta[0] + z_u @ beta[1:]).reshape(J, D)
