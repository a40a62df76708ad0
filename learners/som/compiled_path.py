"""The compiled hot path of the visuomotor map: ``act`` and ``learn`` in one kernel call each
(``learners/som/kernels.py``, numba), with the input checks of ``learners/guards.py`` done inside
the kernels.

A trial is three public calls on a few hundred neurons, so what costs is the Python around the
arithmetic: array checks, copies, schedule evaluation, argument passing. Here each call converts
its arrays, tests their shapes, and makes one kernel call that checks the values (finite, inside
the input box and joint ranges, the same tests as the guards), then computes and writes its
result into arrays the map keeps (no new arrays but the command returned). When a kernel
refuses an input it has changed nothing, and the method returns None: the map's checked path
(the numpy reference's) then raises the error, or counts the skipped trial, with the same
message as without numba. The exploration noise is drawn after the inputs are checked, so a
refused call leaves the generator as it was.

The evaluation's first fine move with ``abar="local-fit"`` fits Ā in one kernel call too
(``learners/som/local_fit_kernel.py``), into the Ā of the fine-move memory.

Used for ``kernel="numba"`` under protocol "mrs"; ``tests/test_kernels.py`` checks it against
the numpy reference over 1,000 trials.
"""

from __future__ import annotations

import numpy as np

from learners.guards import InputBox
from learners.som import kernels
from learners.som.config import NOISE_TERMS, SOMConfig
from learners.som.fine_memory import FineMemory
from learners.som.lattice import Lattice
from learners.som.local_fit import FIT_RADIUS, FIT_RIDGE, FIT_SIGMA
from learners.som.state import MapState
from learners.som.update_rule import Trial

#: Lattices of at least this many neurons search the winner block by block (bounding spheres of
#: 4³-neuron blocks); below it a plain scan is as fast.
PRUNED_SEARCH_MIN = 4096
#: ... whose block bounds are recomputed every this many learned trials (in between, a moved
#: neuron only widens its block's radius).
BLOCK_REFRESH = 1000
#: ε, σ, ε', σ' and the exploration std at the map's current t (``VisuomotorSOM.params``).
Params = tuple[float, float, float, float, float]


class CompiledPath:
    """The compiled ``act`` and ``learn`` of one map: the kernels' constant arguments, the
    arrays the fine-move memory is written into, and the weight tables of the current σ, σ'.

    Args:
        config: the map's options.
        state, memory: the map's learned state and fine-move memory (written in place).
        grid: the map's lattice.
        input_box, joint_box: the boxes its inputs and joint angles are checked against.
    """

    def __init__(
        self,
        config: SOMConfig,
        state: MapState,
        memory: FineMemory,
        grid: Lattice,
        input_box: InputBox,
        joint_box: InputBox,
    ) -> None:
        self.config, self.state, self.memory, self.grid = config, state, memory, grid
        D, J = config.input_dim, len(joint_box.low)
        self.box = np.stack((input_box.centre, input_box.inv_half))  # (2, D)
        self.joints = np.stack(
            (joint_box.low, joint_box.high, joint_box.centre, joint_box.inv_half)
        )  # (4, J)
        self.buffers = (np.empty(D), np.empty(J), np.empty((J, D)), np.empty(D), np.empty(J))
        self.zeros = np.zeros(J)  # no exploration noise
        self._tables: tuple[np.ndarray, np.ndarray, int] | None = None
        self._tables_for: Params | None = None

    def tables(self, params: Params) -> tuple[np.ndarray, np.ndarray, int]:
        """Weight tables of σ and σ' and the cut-off r² of the output averaging for ``params``
        (remembered while the map's params stay the same object)."""
        if self._tables is None or self._tables_for is not params:
            _, sigma, _, sigma_out, _ = params
            r2 = (
                self.grid.cutoff_radius2(sigma_out)
                if self.config.averaging == "neighbourhood"
                else 0
            )
            self._tables = self.grid.weights(sigma), self.grid.weights(sigma_out), r2
            self._tables_for = params
        return self._tables

    def winner(self, u: np.ndarray) -> int:
        """argmin_r |u − w_r|² (the pruned search on large lattices)."""
        state = self.state
        if state.pruned:
            return int(kernels.winner_pruned(
                state.w, state.w2, u, state.shape, state.block_centre, state.block_radius
            ))  # fmt: skip
        return int(kernels.winner(state.w, state.w2, u))

    def coarse(self, u: np.ndarray, params: Params) -> tuple[np.ndarray, np.ndarray]:
        """Unclipped coarse output (J,) and averaged A (J, D) for the checked target u."""
        _, table, r2 = self.tables(params)
        state, (_, J, D) = self.state, self.state.A.shape
        s = self.winner(u)
        theta, abar = np.empty(J), np.empty((J, D))
        kernels.coarse(s, u, state.w, state.theta, state.A, table, r2, state.shape, theta, abar)
        state.remember_winner(u, s)
        return theta, abar

    def act(
        self,
        u: np.ndarray,
        v: np.ndarray | None,
        explore: bool,
        params: Params,
        rng: np.random.Generator,
    ) -> np.ndarray | None:
        """``act`` for inputs of the right shape that pass the checks, else None."""
        u = np.asarray(u, dtype=float)
        if u.shape != (self.config.input_dim,):
            return None
        state, memory, buffers = self.state, self.memory, self.buffers
        if v is None:
            _, table, r2 = self.tables(params)
            s = kernels.act_coarse(
                u, self.box, state.w, state.w2, state.theta, state.A, table, r2, state.shape,
                self.joints, state.block_centre, state.block_radius, *buffers[:3],
            )  # fmt: skip
            if s < 0:
                return None
            memory.start(buffers[0], buffers[1], buffers[2])
            state.remember_winner(u, s)
            return buffers[1].copy()
        v = np.asarray(v, dtype=float)
        if v.shape != u.shape or memory.cmd is None or memory.u is None or memory.abar is None:
            return None
        if kernels.status(u, self.box) != kernels.OK or kernels.status(v, self.box):
            return None
        if u.tobytes() != memory.u.tobytes():  # a new target: Ā around its winner
            memory.abar, memory.u, memory.v = self.coarse(u, params)[1], u.copy(), None
        if memory.v is None and not explore and self.config.abar == "local-fit":
            self._local_fit(u, memory.abar)  # once per target
        std = params[4]
        noise = rng.normal(0.0, std, size=len(self.zeros)) if explore and std > 0 else None
        refine = self.config.refine and memory.v is not None
        v_before = buffers[3] if memory.v is None else memory.v
        cmd_before = buffers[4] if memory.cmd_before is None else memory.cmd_before
        kernels.fine(
            u, v, memory.cmd, memory.abar, v_before, cmd_before, refine, self.config.min_dv,
            self.zeros if noise is None else noise, self.joints,
        )  # fmt: skip
        memory.v, memory.cmd_before = v_before, cmd_before
        return memory.cmd.copy()

    def _local_fit(self, u: np.ndarray, abar: np.ndarray) -> None:
        """Ā of the local fit at target u (``learners/som/local_fit.py``) written into the
        fine-move memory's Ā (``abar``, in place), around the winner the coarse move found
        when the map has not changed since."""
        state = self.state
        s = state.remembered_winner(u)
        if s < 0:
            s = self.winner(u)
        kernels.local_fit(
            s, u, state.w, state.A, state.shape, FIT_RADIUS, FIT_SIGMA, FIT_RIDGE, abar,
        )  # fmt: skip

    def learn(self, trial: Trial, params: Params, t: int) -> int:
        """``learn`` of the trial (u, θ0, v0, θ1, v1) of the right shapes in one kernel call
        (``kernels.learn``: the compiled form of ``update_rule.targets`` and ``mrs_update``):
        ``kernels.LEARNED``, or ``SMALL_DV``, ``NOT_FINITE``, ``OUTSIDE`` with nothing changed.
        ``t`` counts the trials learned before this one."""
        config, state = self.config, self.state
        s = state.remembered_winner(trial[0])  # −1: the kernel searches it
        eps, _, eps_out, _, _ = params
        table_w, table_out, _ = self.tables(params)
        found = int(kernels.learn(
            s, config.theta_target == "coarse-error", *trial, config.learn_min_dv,
            NOISE_TERMS * config.sensing_noise**2,
            state.w, state.w2, state.theta, state.A, self.box, self.joints,
            eps, table_w, eps_out, table_out, state.shape, state.block_centre,
            state.block_radius,
        ))  # fmt: skip
        if found == kernels.LEARNED:
            if state.pruned and t % BLOCK_REFRESH == 0:  # tighten the grown radii
                kernels.refresh_blocks(state.w, state.shape, state.block_centre, state.block_radius)
            state.version += 1
        return found
