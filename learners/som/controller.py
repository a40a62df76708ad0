"""The visuomotor Kohonen map: camera coordinates -> joint angles, learned from the arm's own moves.

:class:`VisuomotorSOM` keeps the map's learned state (``learners/som/state.py``: w, θ, A), the
fine-move memory of the current trial (``learners/som/fine_memory.py``) and its options (one
:class:`~learners.som.config.SOMConfig`). It answers a target u with a coarse command, a sensed
position v with a fine command, and learns from a trial (u, θ0, v0, θ1, v1): the moves and the
choice of update are the trial protocol's (``learners/som/protocols.py``), the update itself is
``learners/som/update_rule.py``, and under ``kernel="numba"`` both run through the compiled
path (``learners/som/compiled_path.py``). ``recover`` adds the detours of
``learners/som/recovery.py``. The equations and the readings of the papers (Ritter, Martinetz &
Schulten 1989/1990; Brause 1989) are on ``docs/map.md``.
"""

from __future__ import annotations

import copy
import math
import operator
import os
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np

from learners.base import Array, Learner, check_pixels
from learners.guards import InputBox, bounds, check_finite, joint_ranges
from learners.persistence import damaged, load_npz, save_npz
from learners.som import kernels
from learners.som import stored as checked
from learners.som.compiled_path import PRUNED_SEARCH_MIN, CompiledPath
from learners.som.config import (
    ABAR,
    AVERAGING,
    DEFAULT_A_INIT,
    DEFAULT_EPS,
    DEFAULT_EPS_OUT,
    DEFAULT_EXPLORE,
    DEFAULT_GAMMA,
    DEFAULT_MIN_DV,
    DEFAULT_SIGMA,
    DEFAULT_SIGMA_OUT,
    DEFAULT_T_MAX,
    PROTOCOLS,
    RULES,
    SHAPE_OPTIONS,
    THETA_TARGETS,
    SOMConfig,
)
from learners.som.fine_memory import FineMemory
from learners.som.lattice import Lattice
from learners.som.local_fit import local_abar
from learners.som.protocols import choose
from learners.som.recovery import recovery_move
from learners.som.schedules import ErrorMonitor
from learners.som.state import MapState
from learners.som.stored import A_LIMIT

__all__ = [
    "ABAR", "AVERAGING", "A_LIMIT", "DEFAULT_A_INIT", "DEFAULT_EPS", "DEFAULT_EPS_OUT",
    "DEFAULT_EXPLORE", "DEFAULT_GAMMA", "DEFAULT_MIN_DV", "DEFAULT_SIGMA", "DEFAULT_SIGMA_OUT",
    "DEFAULT_T_MAX", "FORMAT_VERSION", "KERNELS", "KIND", "PROTOCOLS", "RULES", "THETA_TARGETS",
    "SOMConfig", "VisuomotorSOM", "kernels",
]  # fmt: skip

KERNELS = ("auto", "numba", "numpy")
KIND = "VisuomotorSOM"
FORMAT_VERSION = 1
#: act_batch works in blocks of this many targets: larger matrix products make OpenBLAS start
#: threads, which slows small batches on a shared machine (docs/decisions.md, "The map").
_BATCH_BLOCK = 64


def _kernel(name: str, axes: int) -> str:
    """The hot path to use for a lattice of ``axes`` axes: "numba" or "numpy"."""
    if name not in KERNELS:
        raise ValueError(f"unknown kernel {name!r}; valid kernels: {', '.join(KERNELS)}")
    compiled = kernels.available() and axes <= kernels.MAX_AXES
    if name == "numba" and not compiled:
        raise ValueError(
            f'kernel="numba" needs numba (pip install "visuomotor[fast]") and a lattice of at '
            f'most {kernels.MAX_AXES} axes (got {axes}); use kernel="numpy"'
        )
    return "numba" if name == "numba" or (name == "auto" and compiled) else "numpy"


def _read_only(array: np.ndarray) -> np.ndarray:
    view = array.view()
    view.flags.writeable = False
    return view


def _option(name: str, new_name: str | None = None) -> property:
    """A read-only attribute of the map that reads its configuration (a C-level getter: the
    hot path reads options on every call); ``new_name`` for an old name."""

    def refuse(som: VisuomotorSOM, value: Any) -> None:
        raise AttributeError(
            f"{name} is an option of the map and cannot be set; use "
            f"som = som.with_config({new_name or name}=...) for a map with another {name}"
        )

    return property(operator.attrgetter(f"config.{name}"), refuse)


class VisuomotorSOM(Learner):
    """Kohonen lattice with joint outputs and local linear maps (``docs/map.md``).

    Args:
        joint_lower, joint_upper: joint ranges (J,), rad; every command is clipped into them.
        config: the map's options (:class:`~learners.som.config.SOMConfig`; default: its
            defaults); ``options`` change single fields of it by name (``lattice=(6, 4, 2)``,
            ``protocol="brause"``, schedules as pairs, ...).
        rng: a numpy Generator or a seed; the map's only source of randomness.
        input_low, input_high: (D,) box over which the w_r start uniformly (default [0, 1]^D;
            pass the image bounds for pixels).
        theta_init: (J,) start of every θ_r (default the middle of the joint ranges). Pass a
            pose in the arm configuration that reaches the whole workspace when the middle is
            not one, e.g. for the PUMA ``wrist_ik(workspace centre, arm=1, elbow=1)``: the map
            keeps the configuration it starts in.
        kernel: "numba" (compiled hot path, ``learners/som/kernels.py``; needs the extra ``fast``
            and at most 3 lattice axes), "numpy" (the reference) or "auto" (numba if it can).
            It gives the same moves, so it is not an option of the map (see ``config.py``).
    Raises:
        ValueError: an unknown option name (the valid ones listed), an invalid option value
            (:class:`SOMConfig` names it) or joint ranges, input box or start that do not fit.

    Every field of :class:`SOMConfig` is a read-only attribute (``som.protocol``, ``som.abar``,
    ...); a map with other options and the same learned state is :meth:`with_config`. The
    learned arrays are ``som.learned`` (:class:`~learners.som.state.MapState`), the trial's
    memory ``som.memory`` (:class:`~learners.som.fine_memory.FineMemory`).
    """

    def __init__(
        self,
        joint_lower: np.ndarray,
        joint_upper: np.ndarray,
        config: SOMConfig | None = None,
        *,
        rng: np.random.Generator | int | None = None,
        input_low: np.ndarray | None = None,
        input_high: np.ndarray | None = None,
        theta_init: np.ndarray | None = None,
        kernel: str = "auto",
        **options: Any,
    ) -> None:
        self._config = SOMConfig.of(config, **options)
        self.lower, self.upper = joint_ranges(joint_lower, joint_upper)  # (J,) each
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        c = self._config
        D, J = c.input_dim, self.n_joints
        low, high = bounds(
            ("input_low", "input_high"),
            np.zeros(D) if input_low is None else input_low,
            np.ones(D) if input_high is None else input_high,
            D,
        )
        self.input_low, self.input_high = low, high
        self._input_box = InputBox(low, high, "input box")
        self._joint_box = InputBox(self.lower, self.upper, "joint ranges")
        # u, θ0, v0, θ1, v1 of a trial side by side, checked at once
        self._trial_box = InputBox(
            np.concatenate((low, self.lower, low, self.lower, low)),
            np.concatenate((high, self.upper, high, self.upper, high)),
            "trial's input box and joint ranges",
        )
        start = (self.lower + self.upper) / 2 if theta_init is None else theta_init
        start = np.array(start, dtype=float).ravel()
        check_finite(theta_init=start)
        if start.shape != (J,):
            raise ValueError(f"theta_init must have shape ({J},), got {start.shape}")
        self.grid = Lattice(c.lattice)
        self.coords = self.grid.coords  # (N, L) lattice coordinates of each neuron
        self.kernel = _kernel(kernel, len(c.lattice))
        self._protocol = choose(c.protocol)
        shape = np.array((1, 1, *c.lattice)[-3:], dtype=np.int64)  # 3-D, for the kernels
        pruned = self.kernel == "numba" and math.prod(c.lattice) >= PRUNED_SEARCH_MIN
        blocks = math.prod(-(-int(n) // kernels.BLOCK) for n in shape)
        N = self.n_neurons
        w = self.rng.uniform(low, high, size=(N, D))  # (N, D)
        theta = np.tile(start, (N, 1))  # (N, J)
        a_std = c.a_init * np.mean(self.upper - self.lower) / np.mean(high - low)
        A = self.rng.normal(0.0, a_std, size=(N, J, D)) if a_std > 0 else np.zeros((N, J, D))
        self.learned = MapState(
            w, theta, A, shape, np.zeros((blocks, D) if pruned else (0, 1)),
            np.zeros(blocks if pruned else 0),
        )  # fmt: skip
        self.memory = FineMemory()
        self.t = 0
        self.skipped = {"not_visible": 0, "small_dv": 0}
        self._monitor = None if c.continual is None else ErrorMonitor(c.continual)
        self._params: tuple[float, float, float, float, float] = (0.0,) * 5
        self._params_t = -1
        compiled = self.kernel == "numba" and c.protocol == "mrs"
        self._compiled = (
            CompiledPath(c, self.learned, self.memory, self.grid, self._input_box, self._joint_box)
            if self.kernel == "numba"
            else None
        )
        self._compiled_moves = compiled  # the compiled act and learn (protocol "mrs")

    # ----------------------------------------------------------------------------- options
    @property
    def config(self) -> SOMConfig:
        """The map's options (frozen; :meth:`with_config` gives a map with others)."""
        return self._config

    @property
    def monitor(self) -> ErrorMonitor | None:
        """The continual mode's error monitor (None without ``continual``)."""
        return self._monitor

    @property
    def fine_moves_need_sight(self) -> bool:
        """Whether a fine move corrects from the position sensed after the previous move
        (protocol "mrs"), so that a trial stops, or recovers, when the marker is not seen."""
        return self._protocol.fine_moves_need_sight

    @property
    def recovers(self) -> bool:
        """Whether :meth:`recovery_move` gives detours (``recover``)."""
        return self._config.recover

    def with_config(self, **changes: Any) -> VisuomotorSOM:
        """A new map with the options ``changes`` (SOMConfig field names) and this map's learned
        state: copies of w, θ, A, t, the skip counters, the generator state and the continual
        mode's monitor (a fresh one when ``continual`` is given). The fine-move memory starts
        empty: the next ``act`` must be a coarse one. The kernel stays this map's.

        Raises:
            ValueError: an unknown option, an invalid value, or a change of ``lattice`` or
                ``input_dim`` (the learned arrays have their shape).
        """
        config = SOMConfig.of(self._config, **changes)
        fixed = [k for k in SHAPE_OPTIONS if getattr(config, k) != getattr(self._config, k)]
        if fixed:
            raise ValueError(
                f"{', '.join(fixed)} cannot change on a learned map (its arrays have that "
                "shape); build a new VisuomotorSOM instead"
            )
        monitor = None if "continual" in changes else self._monitor
        return type(self)._restored(
            self.lower, self.upper, config, self.input_low, self.input_high, self.kernel,
            (self.learned.w, self.learned.theta, self.learned.A), self.t, self.skipped,
            copy.deepcopy(self.rng), monitor and ErrorMonitor(monitor.params, monitor.state()),
            FineMemory(),
        )  # fmt: skip

    @classmethod
    def _restored(
        cls,
        lower: np.ndarray,
        upper: np.ndarray,
        config: SOMConfig,
        input_low: np.ndarray,
        input_high: np.ndarray,
        kernel: str,
        arrays: tuple[np.ndarray, np.ndarray, np.ndarray],
        t: int,
        skipped: dict[str, int],
        rng: np.random.Generator,
        monitor: ErrorMonitor | None,
        memory: FineMemory,
    ) -> VisuomotorSOM:
        """A map of these options holding copies of a learned state (w, θ, A), its counts, its
        generator, monitor and fine-move memory."""
        som = cls(
            lower, upper, config, rng=0, input_low=input_low, input_high=input_high, kernel=kernel
        )
        som.learned.w, som.learned.theta, som.learned.A = (a.copy() for a in arrays)
        som.t, som.skipped, som.rng = t, dict(skipped), rng
        if monitor is not None:
            som._monitor = monitor
        som.memory.take(memory)
        som._sync()
        return som

    # ----------------------------------------------------------------------------- state
    @property
    def w(self) -> np.ndarray:
        """(N, D) positions of the neurons in input space (read-only view; assign to set)."""
        return _read_only(self.learned.w)

    @w.setter
    def w(self, value: np.ndarray) -> None:
        w = self._checked("w", value, self.learned.w.shape)
        self._input_box.check("w", w)
        self.learned.w = w
        self._sync()

    @property
    def theta(self) -> np.ndarray:
        """(N, J) joint angles of the neurons, rad (read-only view; assign to set)."""
        return _read_only(self.learned.theta)

    @theta.setter
    def theta(self, value: np.ndarray) -> None:
        self.learned.theta = self._checked("theta", value, self.learned.theta.shape)

    @property
    def A(self) -> np.ndarray:
        """(N, J, D) local linear maps, rad per input unit (read-only view; assign to set)."""
        return _read_only(self.learned.A)

    @A.setter
    def A(self, value: np.ndarray) -> None:
        a = self._checked("A", value, self.learned.A.shape)
        checked.check_linear_map("A", a, self.upper - self.lower, self.input_high - self.input_low)
        self.learned.A = a

    @staticmethod
    def _checked(name: str, value: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        a = np.array(value, dtype=float)  # a copy: the map owns its arrays
        if a.shape != shape:
            raise ValueError(f"{name} must have the map's shape {shape}, got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} contains NaN or inf; the map needs finite values")
        return a

    # ----------------------------------------------------------------------------- structure
    @property
    def n_joints(self) -> int:
        return int(self.lower.shape[0])

    @property
    def n_neurons(self) -> int:
        return math.prod(self._config.lattice)

    def _sync(self) -> None:
        """Derived data: |w_r|², the block spheres, parameters for the current t."""
        self.learned.w_changed()
        self._params_t = -1

    def params(self) -> tuple[float, float, float, float, float]:
        """ε, σ, ε', σ' and the exploration std at t = trials learned so far."""
        c = self._config
        t, T = self.t, c.t_max
        if self._monitor is None and t > T:
            t = T  # the floors: the same values from t_max on
        if self._params_t != t:
            frac = min(t, T) / T if self._monitor is None else self._monitor.fraction(t, T)
            eps, sigma, eps_out, sigma_out, explore = (
                s.at(frac) for s in (c.eps, c.sigma, c.eps_out, c.sigma_out, c.explore)
            )
            self._params = (eps, sigma, eps_out, sigma_out, explore)
            self._params_t = t
        return self._params

    def winner(self, u: np.ndarray) -> int:
        """argmin_r |u − w_r|² = argmin_r |w_r|² − 2 w_r·u for a checked target u (D,)."""
        if self._compiled is not None:
            return self._compiled.winner(u)
        return int((self.learned.w2 - 2.0 * (self.learned.w @ u)).argmin())

    # ----------------------------------------------------------------------------- acting
    def reset(self) -> None:
        """Forget the previous command; the next ``act`` must be a coarse one."""
        self.memory.take(FineMemory())

    def check_input(self, name: str, x: np.ndarray) -> np.ndarray:
        """x as a finite (D,) float array in the input box, else ValueError saying what is
        wrong."""
        a = np.asarray(x, dtype=float)
        if not (a.shape == (self._config.input_dim,) and math.isfinite(a @ a)):
            check_pixels(name, a, self._config.input_dim)  # raises for a wrong shape or NaN
        self._input_box.check(name, a)
        return a

    def _check_trial(self, *arrays: np.ndarray) -> None:
        """ValueError if a finite one of u, θ0, v0, θ1, v1 lies far outside the input box or
        the joint ranges (NaN and inf are left to the other checks: not seen, or refused)."""
        if self._trial_box.inside(np.concatenate(arrays)):  # one test for the usual case
            return
        names = ("u", "theta0", "v0", "theta1", "v1")
        boxes = (self._input_box, self._joint_box, self._input_box, self._joint_box)
        for name, box, a in zip(names, (*boxes, self._input_box), arrays, strict=True):
            if np.isfinite(a).all():
                box.check(name, a)

    def clip(self, theta: np.ndarray) -> np.ndarray:
        """Joint angles (..., J) clipped into the joint ranges."""
        return np.minimum(np.maximum(theta, self.lower), self.upper)

    def coarse_output(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unclipped coarse output θ0 (J,) and averaged A (J, D) for the checked target u; the
        winner is remembered for the fine moves and the learning step."""
        if self._compiled is not None:
            return self._compiled.coarse(u, self.params())
        state, grid = self.learned, self.grid
        sigma_out = self.params()[3]
        averaged = self._config.averaging == "neighbourhood"
        r2 = grid.cutoff_radius2(sigma_out) if averaged else 0
        s = self.winner(u)
        state.remember_winner(u, s)
        if r2 > 0:
            box, g = grid.neighbours(s, sigma_out)
            if g.size > 1:
                K, (_, J, D) = g.size, state.A.shape
                gn = g.ravel() / g.sum()  # (K,) the box's neurons, C order
                a_k = grid.view(state.A, box).reshape(K, J * D)  # (K, J·D)
                du = gn[:, None] * (u - grid.view(state.w, box).reshape(K, D))  # (K, D)
                theta = gn @ grid.view(state.theta, box).reshape(K, J)
                theta += np.einsum("kjd,kd->j", a_k.reshape(K, J, D), du)
                return theta, (gn @ a_k).reshape(J, D)
        a = state.A[s]
        return state.theta[s] + a @ (u - state.w[s]), a.copy()

    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        """Coarse command for target u, or, given v, the next fine command.

        Args:
            u: target in input space (pixels), (D,).
            v: effector position sensed after the previous command, (D,); None for the coarse
                move. Fine moves may follow each other: θ_{k+1} = θ_k + Ā (u − v_k).
            explore: add N(0, explore(t)²) joint noise to a fine command (training only).
        Returns:
            joint command (J,), rad, clipped into [joint_lower, joint_upper].
        Raises:
            ValueError: u or v of the wrong shape or not finite, or a fine move without a coarse
                one since the last ``reset()``; the map and its memory are then unchanged.
        """
        if self._config.recover:
            if v is None:
                self.memory.forget_seen()
            else:
                self.memory.remember_seen(v, self._config.input_dim)
        if self._compiled_moves and self._compiled is not None:
            command = self._compiled.act(u, v, explore, self.params(), self.rng)
            if command is not None:
                return command  # else an input the kernels refuse: the checked path says why
        if v is None:
            return self._protocol.coarse(self, u)
        return self._protocol.fine(self, u, v, explore)

    def recovery_move(self, u: np.ndarray, attempt: int) -> np.ndarray | None:
        """With ``recover``: the command (J,) of detour ``attempt`` (0, 1, ...) for target u
        after a move whose marker a camera did not see (``learners/som/recovery.py``), or None
        when no attempt is left (or ``recover`` is off); the next ``act(u, v)`` corrects from
        the detour.

        Raises:
            ValueError: u of the wrong shape or not finite, or no coarse move since the last
                ``reset()``.
        """
        if not self._config.recover:
            return None
        u = self.check_input("u", u)
        middle = self.learned.w.mean(axis=0)  # (D,)
        return recovery_move(
            self.memory, u, attempt, middle, lambda goal: self.act_batch(goal[None])[0], self.clip
        )

    def local_fit_abar(self, u: np.ndarray) -> np.ndarray:
        """Ā (J, D) of the local fit at target u (``learners/som/local_fit.py``)."""
        s = self.learned.remembered_winner(u)
        state = self.learned
        return local_abar(self.grid, s if s >= 0 else self.winner(u), u, state.w, state.A)

    def act_batch(self, U: np.ndarray) -> np.ndarray:
        """Coarse commands for many targets: (M, D) -> (M, J), the same as ``act`` row by row.

        Does not touch the fine-move memory. Raises ValueError for a wrong shape or NaN/inf.
        """
        U = np.asarray(U, dtype=float)
        D = self._config.input_dim
        if U.ndim != 2 or U.shape[1] != D:
            raise ValueError(f"U must have shape (M, {D}), got {U.shape}")
        if not np.all(np.isfinite(U)):
            raise ValueError("U contains NaN or inf; pass sensed pixels of visible targets")
        self._input_box.check("U", U)
        out = np.empty((len(U), self.n_joints))
        state = self.learned
        for i in range(0, len(U), _BATCH_BLOCK):
            block = U[i : i + _BATCH_BLOCK]
            s = (state.w2[None, :] - 2.0 * (block @ state.w.T)).argmin(1)  # (M,)
            out[i : i + _BATCH_BLOCK] = self._protocol.coarse_batch(self, block, s)
        return out

    # ----------------------------------------------------------------------------- learning
    def learn_stale(self, u: Array, theta0: Array, v0: Array, theta1: Array, v1: Array) -> bool:
        """:meth:`learn` from a trial whose coarse command θ0 an earlier state of the map gave
        (a worker's copy, ``envs.harness.workers``). MRS's coarse-error target
        θ_s + A_s (u − v0) corrects the map's command now by what θ0 missed; here it is moved by
        θ0 − the map's command now for u (θ* = θ_s + A_s (u − v0) + θ0 − θ0_now), the correction
        of θ0 itself. The other targets hold no θ0 of the map's and are :meth:`learn`'s. It
        runs the numpy reference path."""
        shift = None
        c = self._config
        if c.protocol == "mrs" and c.theta_target == "coarse-error":
            u_a = np.asarray(u, dtype=float)
            if u_a.shape == (c.input_dim,) and np.isfinite(u_a).all():
                shift = np.asarray(theta0, dtype=float) - self.act_batch(u_a[None])[0]
        return self.learn(u, theta0, v0, theta1, v1, theta_shift=shift)

    def learn(
        self,
        u: Array,
        theta0: Array,
        v0: Array,
        theta1: Array,
        v1: Array,
        *,
        theta_shift: np.ndarray | None = None,
    ) -> bool:
        """One training trial: target u, coarse command θ0 -> sensed v0, fine θ1 -> sensed v1
        (``theta_shift``: see :meth:`learn_stale`; it takes the numpy reference path).

        Returns:
            True if the map learned; False if the trial was skipped and counted in ``skipped``:
            "not_visible" when v0 or v1 holds NaN/inf (a marker not seen), "small_dv" when
            |v1 − v0| < ``min_dv`` (or 5σ with ``sensing_noise``). Only learned trials
            advance t.
        Raises:
            ValueError: u not finite or not (D,), θ0/θ1 not finite or not (J,), v0/v1 not
                (D,), or any of them far outside the input box or joint ranges
                (``learners.guards``); the map is then unchanged.
        """
        D, J = self._config.input_dim, self.n_joints
        u, v0, v1 = np.asarray(u, dtype=float), np.asarray(v0, dtype=float), np.asarray(v1, float)
        theta0, theta1 = np.asarray(theta0, dtype=float), np.asarray(theta1, dtype=float)
        fast_ok = u.shape == (D,) and theta0.shape == theta1.shape == (J,)
        shapes_ok = fast_ok and v0.shape == (D,) == v1.shape
        trial = (u, theta0, v0, theta1, v1)
        if shapes_ok:
            if self._compiled_moves and theta_shift is None:
                learned = self._learn_compiled(trial)
                if learned is not None:
                    return learned  # else an input is wrong: see below
            self._check_trial(*trial)
        if not (fast_ok and math.isfinite(u @ u + theta0 @ theta0 + theta1 @ theta1)):
            check_pixels("u", u, D)  # the slow path, which names what is wrong
            check_pixels("theta0", theta0, J)
            check_pixels("theta1", theta1, J)
        for name, v in (("v0", v0), ("v1", v1)):
            if v.shape != (D,):
                raise ValueError(f"{name} must have shape ({D},), got {v.shape}")
        if not math.isfinite(v0 @ v0 + v1 @ v1) and not (
            np.isfinite(v0).all() and np.isfinite(v1).all()
        ):
            self.skipped["not_visible"] += 1
            return False
        dv = v1 - v0  # (D,)
        dv2 = float(dv @ dv)
        least = self._config.learn_min_dv
        if dv2 < least * least:
            self.skipped["small_dv"] += 1
            return False
        self._observe(u, v0)
        s = self.learned.remembered_winner(u)  # found by the coarse act for this target
        if s < 0:
            s = self.winner(u)
        self.learned.version += 1
        self._protocol.learn(self, s, trial, dv / dv2, theta_shift)
        self.t += 1
        return True

    def _observe(self, u: np.ndarray, v0: np.ndarray) -> None:
        """The continual mode's monitor sees the coarse error of a usable trial (the fine move
        hides a shift of the images); a re-adaptation runs the schedules back."""
        if self._monitor is not None:
            e = u - v0
            if self._monitor.observe(self.t, self._config.t_max, math.sqrt(float(e @ e))):
                self._params_t = -1

    def _learn_compiled(self, trial: tuple[np.ndarray, ...]) -> bool | None:
        """``learn`` in one kernel call: True (learned), False (skipped, |Δv| < min_dv), None
        (an input not finite or far outside its box; nothing changed)."""
        assert self._compiled is not None
        u, theta0, v0, theta1, v1 = trial
        if self._monitor is not None:  # it sees the trial first, as in the reference learn
            self._check_trial(*trial)
            if not math.isfinite(u @ u + theta0 @ theta0 + theta1 @ theta1 + v0 @ v0 + v1 @ v1):
                return None
            dv = v1 - v0
            least = self._config.learn_min_dv
            if float(dv @ dv) >= least * least:
                self._observe(u, v0)
        found = self._compiled.learn((u, theta0, v0, theta1, v1), self.params(), self.t)
        if found == kernels.LEARNED:
            self.t += 1
            return True
        if found == kernels.SMALL_DV:
            self.skipped["small_dv"] += 1
            return False
        return None

    # ----------------------------------------------------------------------------- persistence
    def save(self, path: str | os.PathLike) -> Path:
        """Write everything needed to continue bit-identically to one ``.npz``, atomically:
        the arrays, the configuration, t, the skip counters, the generator state and the
        fine-move memory."""
        return save_npz(path, KIND, FORMAT_VERSION, *self.state())

    def state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """(configuration, arrays) that :meth:`save` writes; a training run's checkpoint adds
        its own entries beside them (``envs.harness.checkpoint``), and :meth:`load` reads both."""
        config = self._config.to_dict()
        continual = config.pop("continual", None)  # after the counters, as files have it
        config.update(t=self.t, skipped=dict(self.skipped))
        config["rng_state"] = self.rng.bit_generator.state
        if self._monitor is not None:
            config["continual"] = continual
            config["continual_state"] = self._monitor.state()
        arrays = {
            "w": self.learned.w,
            "theta": self.learned.theta,
            "A": self.learned.A,
            "joint_lower": self.lower,
            "joint_upper": self.upper,
            "input_low": self.input_low,
            "input_high": self.input_high,
        }
        arrays.update(self.memory.to_arrays())
        return config, arrays

    @classmethod
    def load(cls, path: str | os.PathLike, kernel: str = "auto") -> VisuomotorSOM:
        """Read a map written by :meth:`save`; ``kernel`` as for the constructor.

        Raises:
            CheckpointError: missing, damaged or truncated file, another kind of state, another
                format version, or contents that do not fit together.
        """
        stored, arrays = load_npz(path, KIND, FORMAT_VERSION)
        try:
            t, skipped = checked.counts(stored)
            config = SOMConfig.from_dict(stored)
            rng = checked.generator(stored["rng_state"])
            lower, upper = checked.ranges(arrays, "joint_lower", "joint_upper")
            D = config.input_dim
            low, high = checked.ranges(arrays, "input_low", "input_high", D)
            N, J = math.prod(config.lattice), len(lower)
            # the arrays' sizes before the lattice's: no huge allocation follows a damaged lattice
            w, theta, A = (
                checked.array(arrays, name, shape)
                for name, shape in (("w", (N, D)), ("theta", (N, J)), ("A", (N, J, D)))
            )
            checked.within("theta", theta, lower, upper, "the stored joint ranges")
            som = cls(
                lower, upper, config, rng=0, input_low=low, input_high=high, kernel=kernel
            )  # fmt: skip
            som.w, som.theta, som.A = w, theta, A  # copies; w in the input box, A bounded
            som.t, som.skipped = t, skipped
            if som._monitor is not None:
                state = checked.monitor_state(stored["continual_state"], t)
                som._monitor = ErrorMonitor(som._monitor.params, state)
            som.rng = rng
            som.memory.take(FineMemory.from_arrays(arrays, lower, upper, som._input_box))
            som._sync()
        except (KeyError, TypeError, ValueError, AttributeError, IndexError, OverflowError) as exc:
            raise damaged(path, KIND, exc) from exc
        return som


for _field in fields(SOMConfig):  # every option a read-only attribute of the map
    setattr(VisuomotorSOM, _field.name, _option(_field.name))
VisuomotorSOM.rule = _option("rule", "theta_target")  # type: ignore[attr-defined]  # the old name
del _field
