"""The update rule of the visuomotor map: what one trial teaches it, in plain numpy.

A trial is (u, θ0, v0, θ1, v1): target u, coarse command θ0 sensed at v0, fine command θ1 sensed
at v1; Δθ = θ1 − θ0, Δv = v1 − v0, s the winner for u. Both targets are taken from the map
before the trial's update:

    A* = A_s + (Δθ − A_s Δv) Δv^T / |Δv|²                   (Widrow-Hoff; MRS; Brause 3.10)
         (+ 3σ² A_s / |Δv|² with ``sensing_noise`` σ > 0: errors in variables, docs/map.md)
    θ* = θ_s + A_s (u − v0)     ``theta_target="coarse-error"`` (MRS 1989/90)
    θ* = θ1 + A_s (w_s − v1)    ``theta_target="fine-error"`` (Brause 3.9)

then :func:`mrs_update` (Gaussian neighbourhoods, two rates) or :func:`brause_update` (Brause's
step neighbourhood and one rate γ). θ_r are clipped into the joint ranges after the update.
The compiled kernel ``learners.som.kernels.learn`` is the compiled form of :func:`targets`
followed by :func:`mrs_update` (``tests/test_update_rule.py`` checks that they agree).
"""

from __future__ import annotations

import numpy as np

from learners.som.lattice import Lattice
from learners.som.state import MapState

#: One trial: target u, coarse command θ0, sensed v0, fine command θ1, sensed v1.
Trial = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def widrow_hoff_target(
    a_s: np.ndarray, trial: Trial, dv_n: np.ndarray, noise_term: float = 0.0
) -> np.ndarray:
    """A* (J, D) from the winner's A_s (J, D) and ``dv_n`` = Δv / |Δv|² (D,); ``noise_term`` =
    3σ² adds 3σ² A_s / |Δv|² (``sensing_noise``)."""
    _, theta0, v0, theta1, v1 = trial
    a_star = a_s + np.multiply.outer((theta1 - theta0) - a_s @ (v1 - v0), dv_n)  # (J, D)
    if noise_term > 0:
        a_star += (noise_term * float(dv_n @ dv_n)) * a_s
    return a_star


def theta_target(kind: str, theta_s: np.ndarray, a_s: np.ndarray, w_s: np.ndarray, trial: Trial):
    """θ* (J,): "coarse-error" θ_s + A_s (u − v0), "fine-error" θ1 + A_s (w_s − v1)."""
    u, _, v0, theta1, v1 = trial
    if kind == "coarse-error":
        return theta_s + a_s @ (u - v0)
    return theta1 + a_s @ (w_s - v1)


def targets(
    kind: str, state: MapState, s: int, trial: Trial, dv_n: np.ndarray, noise_term: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """(θ*, A*) of winner s from the map before the update (module docstring)."""
    a_s = state.A[s]  # (J, D)
    return (
        theta_target(kind, state.theta[s], a_s, state.w[s], trial),
        widrow_hoff_target(a_s, trial, dv_n, noise_term),
    )


def mrs_update(
    state: MapState,
    lattice: Lattice,
    s: int,
    u: np.ndarray,
    theta_star: np.ndarray,
    a_star: np.ndarray,
    rates: tuple[float, float, float, float],
    lower: np.ndarray,
    upper: np.ndarray,
) -> None:
    """MRS's update around winner s, in place; ``rates`` = (ε, σ, ε', σ'):

    w_r += ε h_rs (u − w_r),  h_rs = exp(−|r − s|² / 2σ²)               (Brause 3.5)
    θ_r += ε' h'_rs (θ* − θ_r), clipped;  A_r += ε' h'_rs (A* − A_r)    (3.6, 3.8; σ')
    """
    eps, sigma, eps_out, sigma_out = rates
    box, h = lattice.neighbours(s, sigma)  # a box of the lattice, h = 0 at its far corners
    w_k = lattice.view(state.w, box)  # (*b, D) views: the updates write through
    w_k += (eps * h)[..., None] * (u - w_k)
    lattice.view(state.w2, box)[...] = np.einsum("...d,...d->...", w_k, w_k)
    box, h = lattice.neighbours(s, sigma_out)
    step = eps_out * h  # (*b,)
    theta_k, a_k = lattice.view(state.theta, box), lattice.view(state.A, box)  # (*b, J), (*b, J, D)
    theta_k += step[..., None] * (theta_star - theta_k)
    theta_k[...] = np.minimum(np.maximum(theta_k, lower), upper)
    a_k += step[..., None, None] * (a_star - a_k)


def brause_update(
    state: MapState,
    lattice: Lattice,
    s: int,
    u: np.ndarray,
    theta_star: np.ndarray,
    a_star: np.ndarray,
    gamma: float,
    sigma: float,
    lower: np.ndarray,
    upper: np.ndarray,
) -> None:
    """Brause's update around winner c = s, in place, one rate γ and his step neighbourhood
    (3.2), h = 1 for |y_k − y_c| ≤ σ, else 0, for w, Θ and A alike:

        w_k += γ (x − w_k),  Θ_k += γ (Θ* − Θ_k) clipped,  A_k += γ (A* − A_k)   (3.5, 3.8)
    """
    k = lattice.within(s, sigma)  # (K,) the neurons with h = 1
    state.w[k] += gamma * (u - state.w[k])
    state.w2[k] = np.einsum("kd,kd->k", state.w[k], state.w[k])
    state.theta[k] = np.minimum(
        np.maximum(state.theta[k] + gamma * (theta_star - state.theta[k]), lower), upper
    )
    state.A[k] += gamma * (a_star - state.A[k])
