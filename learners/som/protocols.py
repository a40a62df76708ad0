"""The trial protocols of the visuomotor map, one class each, chosen once when a map is built.

A protocol says how the map moves (the coarse move, the fine moves, many coarse moves at once)
and which update rule a trial feeds (``learners/som/update_rule.py``). It works on the map
through the public members that :class:`MapParts` lists: the learned state, the fine-move
memory, the options and the map's shared steps (the checked inputs, the winner, the averaged
coarse output). ``docs/map.md`` has the equations:

- :class:`MRS`: Ritter, Martinetz & Schulten's loop with this project's additions (numpy; the
  map sends inputs of the right shape through the compiled kernels first under
  ``kernel="numba"``, ``learners/som/compiled_path.py``);
- :class:`Brause`: Brause's own loop (§3): coarse Θ_c, fine (3.7), learning (3.9)/(3.10) with
  one rate γ and the step neighbourhood (3.2).
"""

from __future__ import annotations

from typing import Protocol as Structural

import numpy as np

from learners.som.config import NOISE_TERMS, SOMConfig
from learners.som.fine_memory import FineMemory
from learners.som.lattice import Lattice
from learners.som.schedules import harmonic
from learners.som.state import MapState
from learners.som.update_rule import Trial, brause_update, mrs_update, targets

FINE_FIRST = "a fine move act(u, v) needs a coarse act(u) first (after reset)"


class MapParts(Structural):
    """What a protocol uses of the map (``VisuomotorSOM`` has them all)."""

    learned: MapState
    memory: FineMemory
    grid: Lattice
    rng: np.random.Generator
    t: int
    lower: np.ndarray  # (J,) joint ranges, rad
    upper: np.ndarray

    @property
    def config(self) -> SOMConfig: ...

    @property
    def n_joints(self) -> int: ...

    def params(self) -> tuple[float, float, float, float, float]: ...

    def check_input(self, name: str, x: np.ndarray) -> np.ndarray: ...

    def winner(self, u: np.ndarray) -> int: ...

    def coarse_output(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def local_fit_abar(self, u: np.ndarray) -> np.ndarray: ...

    def clip(self, theta: np.ndarray) -> np.ndarray: ...


class TrialProtocol:
    """How a map moves and learns; subclasses implement every method."""

    #: The name the map, the trial loop and the scripts know the protocol by.
    name = ""
    #: Whether a fine move corrects from the position sensed after the previous move (so that
    #: the trial loop stops, or recovers, when a camera loses the marker).
    fine_moves_need_sight = True

    def coarse(self, som: MapParts, u: np.ndarray) -> np.ndarray:
        """The clipped coarse command (J,) for target u; starts the fine-move memory."""
        raise NotImplementedError

    def fine(self, som: MapParts, u: np.ndarray, v: np.ndarray, explore: bool) -> np.ndarray:
        """The clipped next fine command (J,) for target u after sensing v."""
        raise NotImplementedError

    def coarse_batch(self, som: MapParts, U: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Coarse commands (M, J) for targets U (M, D) with winners s (M,)."""
        raise NotImplementedError

    def learn(
        self,
        som: MapParts,
        s: int,
        trial: Trial,
        dv_n: np.ndarray,
        theta_shift: np.ndarray | None = None,
    ) -> None:
        """Update the map from a checked, usable trial (u, θ0, v0, θ1, v1) whose winner is s.

        Args:
            dv_n: (v1 − v0) / |v1 − v0|², (D,).
            theta_shift: (J,) added to a θ target that holds θ0 implicitly (MRS's coarse-error
                θ_s + A_s (u − v0) assumes θ0 is the map's command now): θ0 − the map's command
                now, for a trial whose θ0 an earlier map gave (``VisuomotorSOM.learn_stale``).
        """
        raise NotImplementedError


class MRS(TrialProtocol):
    """Ritter, Martinetz & Schulten's loop with this project's additions (numpy reference)."""

    name = "mrs"

    def coarse(self, som: MapParts, u: np.ndarray) -> np.ndarray:
        u = som.check_input("u", u)
        theta, abar = som.coarse_output(u)
        command = som.clip(theta)
        som.memory.start(u.copy(), command, abar)
        return command.copy()

    def fine(self, som: MapParts, u: np.ndarray, v: np.ndarray, explore: bool) -> np.ndarray:
        u = som.check_input("u", u)
        v = som.check_input("v", v)
        memory, config = som.memory, som.config
        if memory.cmd is None or memory.u is None or memory.abar is None:
            raise ValueError(FINE_FIRST)
        if u.tobytes() != memory.u.tobytes():  # a new target: Ā around its winner
            memory.abar, memory.u, memory.v = som.coarse_output(u)[1], u.copy(), None
        if memory.v is None and not explore and config.abar == "local-fit":
            memory.abar = som.local_fit_abar(u)
        if config.refine and memory.v is not None and memory.cmd_before is not None:
            dv = v - memory.v
            dv2 = float(dv @ dv)
            if dv2 >= config.min_dv * config.min_dv:  # Broyden: Ā += (Δθ − ĀΔv) Δv^T / |Δv|²
                dth = memory.cmd - memory.cmd_before
                memory.abar = memory.abar + np.multiply.outer(dth - memory.abar @ dv, dv / dv2)
        theta = memory.cmd + memory.abar @ (u - v)
        if explore and som.params()[4] > 0:
            theta = theta + som.rng.normal(0.0, som.params()[4], size=som.n_joints)
        memory.after_fine(v, som.clip(theta))
        return memory.cmd.copy()

    def coarse_batch(self, som: MapParts, U: np.ndarray, s: np.ndarray) -> np.ndarray:
        state, grid = som.learned, som.grid
        M, (N, J, D) = len(U), state.A.shape
        sigma = som.params()[3]
        r2 = grid.cutoff_radius2(sigma)
        if som.config.averaging == "winner" or r2 < 1:  # the winner alone
            return som.clip(state.theta[s] + np.einsum("mjd,md->mj", state.A[s], U - state.w[s]))
        d2 = grid.distances2(s)  # (M, N) |r − s_m|²
        G = grid.weights(sigma).take(np.minimum(d2, r2 + 1))  # (M, N)
        G /= G.sum(1, keepdims=True)
        offset = state.theta - np.einsum("njd,nd->nj", state.A, state.w)  # θ_r − A_r w_r, (N, J)
        GA = (G @ state.A.reshape(N, J * D)).reshape(M, J, D)  # Ā per target
        return som.clip(G @ offset + np.einsum("mjd,md->mj", GA, U))

    def learn(
        self,
        som: MapParts,
        s: int,
        trial: Trial,
        dv_n: np.ndarray,
        theta_shift: np.ndarray | None = None,
    ) -> None:
        config = som.config
        eps, sigma, eps_out, sigma_out, _ = som.params()
        noise_term = NOISE_TERMS * config.sensing_noise**2
        theta_star, a_star = targets(config.theta_target, som.learned, s, trial, dv_n, noise_term)
        if theta_shift is not None and config.theta_target == "coarse-error":
            theta_star = theta_star + theta_shift
        rates = (eps, sigma, eps_out, sigma_out)
        mrs_update(
            som.learned, som.grid, s, trial[0], theta_star, a_star, rates, som.lower, som.upper
        )


class Brause(TrialProtocol):
    """Brause §3, paper-faithful: the winner's Θ_c, the fine move (3.7) that does not use what
    was sensed (v may be NaN), learning (3.9)/(3.10) with one γ and the step neighbourhood."""

    name = "brause"
    fine_moves_need_sight = False

    def _move(self, som: MapParts, u: np.ndarray, v: np.ndarray | None) -> np.ndarray:
        """Coarse Θ_c, fine Θ_c + A_c (u − w_c) (3.7)."""
        u = som.check_input("u", u)
        memory, state = som.memory, som.learned
        if v is not None and memory.cmd is None:
            raise ValueError(FINE_FIRST)
        s = som.winner(u)
        state.remember_winner(u, s)
        theta = state.theta[s] if v is None else state.theta[s] + state.A[s] @ (u - state.w[s])
        memory.cmd = som.clip(theta)
        return memory.cmd.copy()

    def coarse(self, som: MapParts, u: np.ndarray) -> np.ndarray:
        return self._move(som, u, None)

    def fine(self, som: MapParts, u: np.ndarray, v: np.ndarray, explore: bool) -> np.ndarray:
        return self._move(som, u, v)  # no exploration noise: (3.7) alone

    def coarse_batch(self, som: MapParts, U: np.ndarray, s: np.ndarray) -> np.ndarray:
        return som.clip(som.learned.theta[s])

    def learn(
        self,
        som: MapParts,
        s: int,
        trial: Trial,
        dv_n: np.ndarray,
        theta_shift: np.ndarray | None = None,
    ) -> None:
        """(3.9), (3.10) in the forms of the commands sent (x = u, x_I = v0, x_F = v1), then
        one γ and the step neighbourhood (3.2) for w, Θ and A (their targets hold no θ0 of
        the map's: ``theta_shift`` is not needed)."""
        config = som.config
        theta_star, a_star = targets("fine-error", som.learned, s, trial, dv_n)  # (3.9), (3.10)
        gamma = harmonic(config.gamma.initial, config.gamma.final, som.t, config.t_max)
        brause_update(
            som.learned, som.grid, s, trial[0], theta_star, a_star, gamma, som.params()[1],
            som.lower, som.upper,
        )  # fmt: skip


def choose(name: str) -> TrialProtocol:
    """The protocol ``name`` ("mrs" or "brause")."""
    return Brause() if name == "brause" else MRS()
