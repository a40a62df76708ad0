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

Used for ``kernel="numba"`` under protocol "mrs" (``learners.som.protocols.CompiledMRS``);
``tests/test_kernels.py`` checks it against the numpy reference over 1,000 trials.
"""

from __future__ import annotations

import math

import numpy as np

from learners.som import kernels
from learners.som.config import NOISE_TERMS
from learners.som.local_fit import FIT_RADIUS, FIT_RIDGE, FIT_SIGMA

#: Lattices of at least this many neurons search the winner block by block (bounding spheres of
#: 4³-neuron blocks); below it a plain scan is as fast.
PRUNED_SEARCH_MIN = 4096
#: ... whose block bounds are recomputed every this many learned trials (in between, a moved
#: neuron only widens its block's radius).
BLOCK_REFRESH = 1000


class CompiledPath:
    """Mixin of :class:`learners.som.controller.VisuomotorSOM`: the compiled ``act`` and
    ``learn``."""

    def _init_compiled(self) -> None:
        """Constant kernel arguments and the arrays the fine-move memory is written into."""
        D, J = self.input_dim, self.n_joints
        box, joints = self._input_box, self._joint_box
        self._box = np.stack((box.centre, box.inv_half))  # (2, D)
        self._joints = np.stack((self.lower, self.upper, joints.centre, joints.inv_half))  # (4, J)
        self._memory = (np.empty(D), np.empty(J), np.empty((J, D)), np.empty(D), np.empty(J))
        self._tables: tuple[np.ndarray, np.ndarray, int] | None = None

    def _kernel_tables(self) -> tuple[np.ndarray, np.ndarray, int]:
        """Weight tables of σ and σ' and the cut-off r² of the output averaging at the
        current t (remembered until ``params`` changes)."""
        _, sigma, _, sigma_out, _ = self.params()  # forgets the tables when t moved them
        if self._tables is None:
            grid = self._grid
            r2 = grid.cutoff_radius2(sigma_out) if self.averaging == "neighbourhood" else 0
            self._tables = grid.weights(sigma), grid.weights(sigma_out), r2
        return self._tables

    def _act_compiled(self, u: np.ndarray, v: np.ndarray | None, explore: bool):
        """``act`` for inputs of the right shape that pass the checks, else None."""
        u = np.asarray(u, dtype=float)
        if u.shape != (self.input_dim,):
            return None
        if v is None:
            _, table, r2 = self._kernel_tables()
            memory = self._memory
            s = kernels.act_coarse(
                u, self._box, self._w, self._w2, self._th, self._A, table, r2, self._shape,
                self._joints, self._block_centre, self._block_radius, *memory[:3],
            )  # fmt: skip
            if s < 0:
                return None
            self._u, self._cmd, self._abar = memory[:3]
            self._v = self._cmd_before = None
            self._last_winner = (u.tobytes(), self._version, s)
            return self._cmd.copy()
        v = np.asarray(v, dtype=float)
        if v.shape != u.shape or self._cmd is None:
            return None
        if kernels.status(u, self._box) != kernels.OK or kernels.status(v, self._box):
            return None
        if u.tobytes() != self._u.tobytes():  # a new target: Ā around its winner
            self._abar, self._u, self._v = self._coarse(u)[1], u.copy(), None
        if self._v is None and not explore and self.abar == "local-fit":
            self._local_fit_compiled(u)  # once per target
        std = self.params()[4]
        noise = self.rng.normal(0.0, std, size=self.n_joints) if explore and std > 0 else None
        refine = self.refine and self._v is not None
        v_before = self._memory[3] if self._v is None else self._v
        cmd_before = self._memory[4] if self._cmd_before is None else self._cmd_before
        kernels.fine(
            u, v, self._cmd, self._abar, v_before, cmd_before, refine, self.min_dv,
            self._zeros if noise is None else noise, self._joints,
        )  # fmt: skip
        self._v, self._cmd_before = v_before, cmd_before
        return self._cmd.copy()

    def _local_fit_compiled(self, u: np.ndarray) -> None:
        """Ā of the local fit at target u (``learners/som/local_fit.py``) written into the
        fine-move memory's Ā, around the winner the coarse move found when the map has not
        changed since."""
        s = self._remembered_winner(u)
        if s < 0:
            s = self._winner(u)
        kernels.local_fit(
            s, u, self._w, self._A, self._shape, FIT_RADIUS, FIT_SIGMA, FIT_RIDGE, self._abar
        )

    def _learn_compiled(
        self, u: np.ndarray, theta0: np.ndarray, v0: np.ndarray, theta1: np.ndarray, v1: np.ndarray
    ) -> bool | None:
        """``learn`` in one kernel call for inputs of the right shapes: True (learned), False
        (skipped, |Δv| < min_dv), None (an input not finite or far outside its box; nothing
        changed). With the continual mode's monitor, the caller has checked the inputs."""
        if self.monitor is not None:  # it sees the trial first, as in the reference learn
            dv = v1 - v0
            finite = math.isfinite(u @ u + theta0 @ theta0 + theta1 @ theta1 + v0 @ v0 + v1 @ v1)
            if not finite:
                return None
            least = self.config.learn_min_dv
            if float(dv @ dv) >= least * least:
                e = u - v0
                if self.monitor.observe(self.t, self.t_max, math.sqrt(float(e @ e))):
                    self._params_t = -1
        s = self._remembered_winner(u)  # −1: the kernel searches it
        eps, _, eps_out, _, _ = self.params()
        table_w, table_out, _ = self._kernel_tables()
        found = kernels.learn(
            s, self.rule == "mrs", u, theta0, v0, theta1, v1, self.config.learn_min_dv,
            NOISE_TERMS * self.sensing_noise**2,
            self._w, self._w2, self._th, self._A, self._box, self._joints,
            eps, table_w, eps_out, table_out, self._shape, self._block_centre,
            self._block_radius,
        )  # fmt: skip
        if found == kernels.LEARNED:
            if self._pruned and self.t % BLOCK_REFRESH == 0:  # tighten the grown radii
                kernels.refresh_blocks(self._w, self._shape, self._block_centre, self._block_radius)
            self._version += 1
            self.t += 1
            return True
        if found == kernels.SMALL_DV:
            self.skipped["small_dv"] += 1
            return False
        return None
