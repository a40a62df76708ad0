"""The trial protocols of the visuomotor map, one class each, chosen once when a map is built.

A protocol says how the map moves (the coarse move, the fine moves, many coarse moves at once)
and how it learns from a trial; the map keeps the arrays and everything the protocols share
(the winner search, the σ'-averaged coarse output, the checks of the inputs). The equations are
in ``learners/som/controller.py``:

- :class:`MRS`: MRS's loop with this project's additions (numpy, the reference);
- :class:`CompiledMRS`: the same through the compiled kernels (``learners/som/compiled_path.py``),
  falling back to :class:`MRS` for an input the kernels refuse, so that the error is the same;
- :class:`Brause`: Brause's own loop (§3): coarse Θ_c, fine (3.7), learning (3.9)/(3.10) with
  one rate γ and the step neighbourhood (3.2).

The protocols are parts of the map: they read and write its arrays in place.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from learners.som.config import NOISE_TERMS
from learners.som.schedules import harmonic

if TYPE_CHECKING:
    from learners.som.controller import VisuomotorSOM

#: One trial: target u, coarse command θ0, sensed v0, fine command θ1, sensed v1.
Trial = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
_FINE_FIRST = "a fine move act(u, v) needs a coarse act(u) first (after reset)"


class Protocol:
    """How a map moves and learns; subclasses implement every method but ``learn_compiled``."""

    #: The name the map, the trial loop and the scripts know the protocol by.
    name = ""

    def coarse(self, som: VisuomotorSOM, u: np.ndarray) -> np.ndarray:
        """The clipped coarse command (J,) for target u; sets the fine-move memory."""
        raise NotImplementedError

    def fine(self, som: VisuomotorSOM, u: np.ndarray, v: np.ndarray, explore: bool) -> np.ndarray:
        """The clipped next fine command (J,) for target u after sensing v."""
        raise NotImplementedError

    def coarse_batch(self, som: VisuomotorSOM, U: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Coarse commands (M, J) for targets U (M, D) with winners s (M,)."""
        raise NotImplementedError

    def learn(self, som: VisuomotorSOM, s: int, trial: Trial, dv_n: np.ndarray) -> None:
        """Update the map from a checked, usable trial (u, θ0, v0, θ1, v1) whose winner is s.

        Args:
            dv_n: (v1 − v0) / |v1 − v0|², (D,).
        """
        raise NotImplementedError

    def learn_compiled(self, som: VisuomotorSOM, trial: Trial) -> bool | None:
        """A whole ``learn`` in one kernel call: True/False as ``learn`` returns, or None to
        take the reference path (no compiled path, or an input the kernel refused)."""
        return None


class MRS(Protocol):
    """Ritter, Martinetz & Schulten's loop with this project's additions (numpy reference)."""

    name = "mrs"

    def coarse(self, som: VisuomotorSOM, u: np.ndarray) -> np.ndarray:
        u = som._vector("u", u)
        theta, som._abar = som._coarse(u)
        som._u, som._v, som._cmd_before = u.copy(), None, None
        som._cmd = som._clip(theta)
        return som._cmd.copy()

    def fine(self, som: VisuomotorSOM, u: np.ndarray, v: np.ndarray, explore: bool) -> np.ndarray:
        u = som._vector("u", u)
        v = som._vector("v", v)
        if som._cmd is None:
            raise ValueError(_FINE_FIRST)
        if u.tobytes() != som._u.tobytes():  # a new target: Ā around its winner
            som._abar, som._u, som._v = som._coarse(u)[1], u.copy(), None
        if som._v is None and not explore and som.abar == "local-fit":
            som._abar = som._local_abar(u)
        if som.refine and som._v is not None:
            dv = v - som._v
            dv2 = float(dv @ dv)
            if dv2 >= som.min_dv * som.min_dv:
                dth = som._cmd - som._cmd_before
                som._abar = som._abar + np.multiply.outer(dth - som._abar @ dv, dv / dv2)
        theta = som._cmd + som._abar @ (u - v)
        if explore and som.params()[4] > 0:
            theta = theta + som.rng.normal(0.0, som.params()[4], size=som.n_joints)
        som._v, som._cmd_before = v.copy(), som._cmd
        som._cmd = som._clip(theta)
        return som._cmd.copy()

    def coarse_batch(self, som: VisuomotorSOM, U: np.ndarray, s: np.ndarray) -> np.ndarray:
        M, (N, J, D) = len(U), som._A.shape
        sigma = som.params()[3]
        r2 = som._grid.cutoff_radius2(sigma)
        if som.averaging == "winner" or r2 < 1:  # the winner alone
            return som._clip(som._th[s] + np.einsum("mjd,md->mj", som._A[s], U - som._w[s]))
        d2 = som._grid.distances2(s)  # (M, N) |r − s_m|²
        G = som._grid.weights(sigma).take(np.minimum(d2, r2 + 1))  # (M, N)
        G /= G.sum(1, keepdims=True)
        offset = som._th - np.einsum("njd,nd->nj", som._A, som._w)  # θ_r − A_r w_r, (N, J)
        GA = (G @ som._A.reshape(N, J * D)).reshape(M, J, D)  # Ā per target
        return som._clip(G @ offset + np.einsum("mjd,md->mj", GA, U))

    def learn(self, som: VisuomotorSOM, s: int, trial: Trial, dv_n: np.ndarray) -> None:
        u, theta0, v0, theta1, v1 = trial
        eps, sigma, eps_out, sigma_out, _ = som.params()
        a_s = som._A[s]  # (J, D), read before any update
        if som.rule == "mrs":
            theta_star = som._th[s] + a_s @ (u - v0)  # (J,)
        else:
            theta_star = theta1 + a_s @ (som._w[s] - v1)
        a_star = a_s + np.multiply.outer((theta1 - theta0) - a_s @ (v1 - v0), dv_n)  # (J, D)
        if som.sensing_noise > 0:  # errors in variables: undo the shrinking (controller.py)
            a_star += (NOISE_TERMS * som.sensing_noise**2 * float(dv_n @ dv_n)) * a_s
        self._update(som, s, u, theta_star, a_star, eps, sigma, eps_out, sigma_out)

    @staticmethod
    def _update(
        som: VisuomotorSOM,
        s: int,
        u: np.ndarray,
        theta_star: np.ndarray,
        a_star: np.ndarray,
        eps: float,
        sigma: float,
        eps_out: float,
        sigma_out: float,
    ) -> None:
        """w_r += ε h (u − w_r); θ_r += ε' h' (θ* − θ_r), clipped; A_r += ε' h' (A* − A_r)."""
        grid = som._grid
        box, h = grid.neighbours(s, sigma)  # a box of the lattice, h = 0 at its far corners
        w_k = grid.view(som._w, box)  # (*b, D) views: the updates write through
        w_k += (eps * h)[..., None] * (u - w_k)
        grid.view(som._w2, box)[...] = np.einsum("...d,...d->...", w_k, w_k)
        box, h = grid.neighbours(s, sigma_out)
        step = eps_out * h  # (*b,)
        theta_k, a_k = grid.view(som._th, box), grid.view(som._A, box)  # (*b, J), (*b, J, D)
        theta_k += step[..., None] * (theta_star - theta_k)
        theta_k[...] = som._clip(theta_k)
        a_k += step[..., None, None] * (a_star - a_k)


class CompiledMRS(MRS):
    """:class:`MRS` through the compiled kernels; an input they refuse takes the reference path,
    which raises the reference's error or counts the skipped trial."""

    def coarse(self, som: VisuomotorSOM, u: np.ndarray) -> np.ndarray:
        command = som._act_compiled(u, None, False)
        return super().coarse(som, u) if command is None else command

    def fine(self, som: VisuomotorSOM, u: np.ndarray, v: np.ndarray, explore: bool) -> np.ndarray:
        command = som._act_compiled(u, v, explore)
        return super().fine(som, u, v, explore) if command is None else command

    def learn_compiled(self, som: VisuomotorSOM, trial: Trial) -> bool | None:
        if som.monitor is not None:  # it observes the trial before the kernel checks it
            som._check_trial(*trial)
        return som._learn_compiled(*trial)


class Brause(Protocol):
    """Brause §3, paper-faithful: the winner's Θ_c, the fine move (3.7) that does not use what
    was sensed (v may be NaN), learning (3.9)/(3.10) with one γ and the step neighbourhood."""

    name = "brause"

    def _move(self, som: VisuomotorSOM, u: np.ndarray, v: np.ndarray | None) -> np.ndarray:
        """Coarse Θ_c, fine Θ_c + A_c (u − w_c) (3.7)."""
        u = som._vector("u", u)
        if v is not None and som._cmd is None:
            raise ValueError(_FINE_FIRST)
        s = som._winner(u)
        som._last_winner = (u.tobytes(), som._version, s)
        theta = som._th[s] if v is None else som._th[s] + som._A[s] @ (u - som._w[s])
        som._cmd = som._clip(theta)
        return som._cmd.copy()

    def coarse(self, som: VisuomotorSOM, u: np.ndarray) -> np.ndarray:
        return self._move(som, u, None)

    def fine(self, som: VisuomotorSOM, u: np.ndarray, v: np.ndarray, explore: bool) -> np.ndarray:
        return self._move(som, u, v)  # no exploration noise: (3.7) alone

    def coarse_batch(self, som: VisuomotorSOM, U: np.ndarray, s: np.ndarray) -> np.ndarray:
        return som._clip(som._th[s])

    def learn(self, som: VisuomotorSOM, s: int, trial: Trial, dv_n: np.ndarray) -> None:
        """(3.9), (3.10) in the forms of the commands sent (x = u, x_I = v0, x_F = v1), then
        one γ and the step neighbourhood (3.2) for w, Θ and A."""
        x, theta0, x_i, theta1, x_f = trial
        a_c, w_c = som._A[s], som._w[s].copy()  # before any update
        theta_star = theta1 + a_c @ (w_c - x_f)  # (3.9), (J,)
        a_star = a_c + np.multiply.outer((theta1 - theta0) - a_c @ (x_f - x_i), dv_n)  # (3.10)
        gamma = harmonic(som.gamma.initial, som.gamma.final, som.t, som.t_max)
        k = som._grid.within(s, som.params()[1])  # (K,) neurons with h = 1
        som._w[k] += gamma * (x - som._w[k])
        som._w2[k] = np.einsum("kd,kd->k", som._w[k], som._w[k])
        som._th[k] = som._clip(som._th[k] + gamma * (theta_star - som._th[k]))
        som._A[k] += gamma * (a_star - som._A[k])


def choose(name: str, kernel: str) -> Protocol:
    """The protocol ``name`` ("mrs" or "brause") of a map whose hot path is ``kernel``."""
    if name == "brause":
        return Brause()
    return CompiledMRS() if kernel == "numba" else MRS()
