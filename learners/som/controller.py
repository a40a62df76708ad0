"""The visuomotor Kohonen map: camera coordinates -> joint angles, learned from the arm's own moves.

Ritter, Martinetz & Schulten (1989), Martinetz, Ritter & Schulten (1990) and Brause (1989) §3.
Neuron r of a lattice holds w_r (where it sits in input space), θ_r (the joint angles that reach
there) and A_r (a local linear map, ≈ the inverse Jacobian ∂θ/∂u). The state is three arrays,
``w`` (N, D), ``theta`` (N, J) and ``A`` (N, J, D), N = prod(lattice), neurons in C order.

Moving (``act``):
    winner   s = argmin_r |u − w_r|                                                  (Brause 3.4)
    coarse   θ0 = Σ_r g_r (θ_r + A_r (u − w_r)) / Σ_r g_r,  g_r = exp(−|r − s|² / 2σ'²)
             (MRS 1990; ``averaging="winner"``: g_r = δ_rs, MRS 1989 and Brause 3.7)
    fine     θ_{k+1} = θ_k + Ā (u − v_k),  Ā = Σ_r g_r A_r / Σ_r g_r, v_k sensed after θ_k
             ``abar="local-fit"`` (not in the papers): Ā is instead the value at u of a linear
             field fitted to the A_r of the winner's lattice box (``learners/som/local_fit.py``);
             exploratory (training) fine moves keep the average, so the map learned is the
             same with either; ``abar="average"`` is the MRS Ā.
             ``refine=True`` (not in the papers): from the second fine move on, Ā first takes
             the Widrow-Hoff step of the previous fine move, Ā += (Δθ − ĀΔv)Δv^T/|Δv|² (a
             Broyden update); ``refine=False`` keeps Ā fixed as MRS do.
             MRS's published moves are ``abar="average", refine=False``.

Learning (``learn``), one trial (u, θ0, v0, θ1, v1), Δθ = θ1 − θ0, Δv = v1 − v0:
    w_r += ε h_rs (u − w_r),    h_rs = exp(−|r − s|² / 2σ²)     (Brause 3.5 with the Gaussian
                                  neighbourhood of Ritter, Martinetz & Schulten, his [RITT3])
    θ_r += ε' h'_rs (θ* − θ_r),  A_r += ε' h'_rs (A* − A_r),  h' of width σ'  (Brause 3.6, 3.8)
    A* = A_s + (Δθ − A_s Δv) Δv^T / |Δv|²                     (Widrow-Hoff; MRS; Brause 3.10)
         ``sensing_noise`` = σ > 0 (not in the papers): A* = A_s + ((Δθ − A_s Δv) Δv^T + 3σ² A_s)
         / |Δv|², errors in variables. The sensed Δv = Δv_true + e1 − e0 holds the errors of
         the two sightings, and the fine move corrected the sensed error u − v0, so e0 is also
         in Δθ, as −A e0: at the true A the step's residual is −A (e1 − e0), and its mean
         product with the sensed Δv is −A (σ² + σ² + σ²) when A inverts the arm's Jacobian (e1
         once, e0 in the sensing and, through the fine move, in the move). A Widrow-Hoff step
         on noisy Δv therefore shrinks A towards zero by about 3σ² against the spread of Δv,
         most where Δv is small (late in training); 3σ² A_s puts that mean back. Trials with
         |Δv| < 5σ are skipped then: there 3σ²/|Δv|² would grow A faster than it shrinks.
    rule "mrs":    θ* = θ_s + A_s (u − v0)    error sensed after the coarse move (MRS 1989/90)
    rule "brause": θ* = θ1 + A_s (w_s − v1)   error sensed after the fine move (Brause 3.9)
All targets are computed from the map before the trial's updates. θ_r are then clipped into the
joint ranges (not in the papers: when the coarse command is clipped, θ* = θ_s + A_s(u − v0)
pushes a θ_r that lies beyond a limit further out with every trial).

Brause states (3.9)/(3.10) for his own protocol: coarse move Θ_c, fine move Θ_c + A_c(x − w_c)
(3.7), x = u, x_I = v0, x_F = v1. For that protocol the "brause" θ* is literally (3.9),
Θ_c + A_c(x − x_F), and with Δθ = A_c(x − w_c) the Widrow-Hoff step is (3.10) as printed,
A_c + A_c((x − x_F) − (w_c − x_I))(x_F − x_I)^T / |x_F − x_I|², since A_c((x − x_F) − (w_c − x_I))
= A_c(x − w_c) − A_c(x_F − x_I) = Δθ − A_c Δv: the garbled-looking (w_c − x_I) term is what
makes the bracket the Widrow-Hoff residual. The forms above use the commands actually sent, so
they also hold for the coarse move with its linear term used here; ``tests/test_som.py``
checks them against the printed equations for Brause's protocol.

Protocols. ``protocol="mrs"`` is everything above. ``protocol="brause"`` is Brause's own loop
(§3), paper-faithful, with none of this project's additions:
    coarse   Θ_c of the winner c alone (no linear term, no averaging)
    fine     Θ_c + A_c (x − w_c)                                                    (3.7)
             it does not use the position x_I sensed after the coarse move (x_I only enters
             learning), so every fine move gives the same command and no ``refine``, no
             exploration noise
    learning Θ* = Θ_c + A_c (x − x_F)                                               (3.9)
             A* = A_c + A_c((x − x_F) − (w_c − x_I)) (x_F − x_I)^T / |x_F − x_I|²  (3.10)
             w_k += γ h (x − w_k), Θ_k += γ h (Θ* − Θ_k), A_k += γ h (A* − A_k)   (3.5, 3.8)
             one γ and one h for w, Θ and A (his (3.8) uses "the neighbourhood function h"
             of (3.2)); h is his step (3.2): 1 for |y_k − y_c| ≤ σ(t), else 0 (σ, the
             "step-width", from the ``sigma`` schedule); γ(t) = ``schedules.harmonic`` from
             ``gamma.initial`` to ``gamma.final``, which satisfies (3.3) (γ → 0, no floor).
    Readings: (3.8) writes u_c only; as in (3.6) every neuron k of N_c moves towards the
    winner's estimate u*_c. (3.9)/(3.10) assume the fine command Θ_c + A_c(x − w_c) was made;
    they are computed in the equivalent forms of the commands actually sent, Θ* = θ1 + A_c(w_c −
    x_F) and A* = A_c + (Δθ − A_c Δv) Δv^T/|Δv|² (the "brause" rule below), which equal the
    printed ones unless a command was clipped at a joint limit (then the printed forms teach A_c
    a move the arm did not make).
    Kept from this project: commands and Θ_k clipped into the joint ranges, trials with
    |Δv| < ``min_dv`` skipped (the division in 3.10). ``rule``, ``averaging``, ``refine``,
    ``eps``, ``eps_out``, ``sigma_out`` and ``explore`` have no effect under this protocol.
    Known weakness: with Δθ = A_c(x − w_c), (3.10) is A* = A_c(I + (e − Δv)Δv^T/|Δv|²),
    e = x − w_c, so A* maps into the range of A_c and only the directions its own moves excite
    are corrected (``tests/test_brause_protocol.py``).

Exploration: Δθ of a fine move is Ā(u − v0), which stays inside the range of Ā, so the
Widrow-Hoff step alone never learns the other directions (with A = 0 it learns nothing). Fine
moves made with ``act(u, v, explore=True)`` (training) add N(0, explore(t)²) joint noise.

Recovery (``recover=True``, not in the papers): when a camera loses the marker after a move,
the trial loop asks for recovery moves (``recovery_move``): detours to poses the map learned,
nearer the middle of what it has seen, until both cameras see the marker; the fine moves then
correct from there (``learners/som/recovery.py``). Off by default: MRS's loop stops the trial.

Options are one :class:`~learners.som.config.SOMConfig`. The protocol is a strategy of
``learners/som/protocols.py`` chosen once when the map is built; :meth:`VisuomotorSOM.with_config`
builds a map with other options and the same learned state.
"""

from __future__ import annotations

import copy
import math
import operator
import os
from pathlib import Path
from typing import Any

import numpy as np

from learners.base import Array, Learner, check_pixels
from learners.guards import InputBox, check_finite, joint_ranges
from learners.persistence import CheckpointError, load_npz, save_npz
from learners.som import kernels, recovery
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
    SOMConfig,
)
from learners.som.lattice import Lattice
from learners.som.local_fit import local_abar
from learners.som.protocols import choose
from learners.som.schedules import ErrorMonitor

__all__ = [
    "ABAR", "AVERAGING", "DEFAULT_A_INIT", "DEFAULT_EPS", "DEFAULT_EPS_OUT", "DEFAULT_EXPLORE",
    "DEFAULT_GAMMA", "DEFAULT_MIN_DV", "DEFAULT_SIGMA", "DEFAULT_SIGMA_OUT", "DEFAULT_T_MAX",
    "FORMAT_VERSION", "KERNELS", "KIND", "PROTOCOLS", "RULES", "SOMConfig", "VisuomotorSOM",
    "kernels",
]  # fmt: skip

KERNELS = ("auto", "numba", "numpy")
#: |A_ij| beyond this many joint spans per input span is refused as damage: a Widrow-Hoff step
#: changes A by at most a joint span per |Δv| >= ``min_dv``, so learning never gets near it.
A_LIMIT = 1e9
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


#: Entries of a saved map beside its configuration, and their JSON types.
_STATE_TYPES: dict[str, type] = {"t": int, "skipped": dict, "rng_state": dict}
#: numpy bit generators a saved map may name (never an arbitrary numpy.random attribute).
_BIT_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")


def _check_state(entries: dict[str, Any]) -> None:
    """ValueError for saved state entries that are missing, of a wrong type or a count < 0."""
    for key, kind in _STATE_TYPES.items():
        value = entries[key]
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise ValueError(f"config entry {key!r} is {value!r}, not of type {kind}")
    counts = entries["skipped"]
    if entries["t"] < 0 or set(counts) != {"not_visible", "small_dv"}:
        raise ValueError(f"t = {entries['t']} or skipped = {counts} is not a valid count")
    if not all(isinstance(n, int) and n >= 0 for n in counts.values()):
        raise ValueError(f"skipped = {counts} holds counts that are not integers >= 0")
    if entries["rng_state"].get("bit_generator") not in _BIT_GENERATORS:
        raise ValueError(f"unknown bit generator in {entries['rng_state']}")


def _option(name: str) -> property:
    """A read-only attribute of the map that reads its configuration (a C-level getter: the
    hot path reads options on every call)."""

    def refuse(som: VisuomotorSOM, value: Any) -> None:
        raise AttributeError(
            f"{name} is an option of the map and cannot be set; use "
            f"som = som.with_config({name}=...) for a map with another {name}"
        )

    return property(operator.attrgetter(f"_config.{name}"), refuse)


class VisuomotorSOM(CompiledPath, Learner):
    """Kohonen lattice with joint outputs and local linear maps (see the module docstring).

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

    The options are read-only attributes (``som.protocol``, ``som.abar``, ...); a map with other
    options and the same learned state is :meth:`with_config`.
    """

    lattice = _option("lattice")
    input_dim = _option("input_dim")
    rule = _option("rule")
    averaging = _option("averaging")
    refine = _option("refine")
    abar = _option("abar")
    t_max = _option("t_max")
    eps = _option("eps")
    sigma = _option("sigma")
    eps_out = _option("eps_out")
    sigma_out = _option("sigma_out")
    explore = _option("explore")
    gamma = _option("gamma")
    a_init = _option("a_init")
    min_dv = _option("min_dv")
    sensing_noise = _option("sensing_noise")
    protocol = _option("protocol")  # the learner interface's protocol: the strategy chosen from it
    continual = _option("continual")
    recover = _option("recover")  # the learner interface's recover: ask for recovery_move

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
        D, J = self.input_dim, self.n_joints
        low = np.zeros(D) if input_low is None else np.array(input_low, dtype=float).ravel()
        high = np.ones(D) if input_high is None else np.array(input_high, dtype=float).ravel()
        check_finite(input_low=low, input_high=high)
        if low.shape != (D,) or high.shape != (D,) or not np.all(low < high):
            raise ValueError(f"input_low/input_high must be ({D},) with low < high: {low}, {high}")
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
        self._grid = Lattice(self.lattice)
        self.kernel = _kernel(kernel, len(self.lattice))
        self._protocol = choose(self.protocol, self.kernel)
        self._shape = np.array((1, 1, *self.lattice)[-3:], dtype=np.int64)  # 3-D, for the kernels
        self._zeros = np.zeros(self.n_joints)  # no exploration noise, for the kernels
        self._pruned = self.kernel == "numba" and math.prod(self.lattice) >= PRUNED_SEARCH_MIN
        blocks = math.prod(-(-n // kernels.BLOCK) for n in self._shape)
        self._block_centre = np.zeros((blocks, D) if self._pruned else (0, 1))
        self._block_radius = np.zeros(blocks if self._pruned else 0)
        self.coords = self._grid.coords  # (N, L) lattice coordinates of each neuron
        N = self.n_neurons
        self._w = self.rng.uniform(low, high, size=(N, D))  # (N, D)
        self._th = np.tile(start, (N, 1))  # (N, J)
        a_std = self.a_init * np.mean(self.upper - self.lower) / np.mean(high - low)
        self._A = self.rng.normal(0.0, a_std, size=(N, J, D)) if a_std > 0 else np.zeros((N, J, D))
        self.t = 0
        self.skipped = {"not_visible": 0, "small_dv": 0}
        continual = self.continual
        self._monitor = None if continual is None else ErrorMonitor(continual)
        self._version = 0  # counts changes of w, for the winner remembered from the coarse act
        self._init_compiled()
        self._sync()
        self.reset()

    # ----------------------------------------------------------------------------- options
    @property
    def config(self) -> SOMConfig:
        """The map's options (frozen; :meth:`with_config` gives a map with others)."""
        return self._config

    @property
    def monitor(self) -> ErrorMonitor | None:
        """The continual mode's error monitor (None without ``continual``)."""
        return self._monitor

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
        som = type(self)(
            self.lower, self.upper, config, rng=0, input_low=self.input_low,
            input_high=self.input_high, kernel=self.kernel,
        )  # fmt: skip
        som._w, som._th, som._A = self._w.copy(), self._th.copy(), self._A.copy()
        som.t, som.skipped = self.t, dict(self.skipped)
        som.rng = copy.deepcopy(self.rng)
        if "continual" not in changes and self._monitor is not None:
            som._monitor = ErrorMonitor(self._monitor.params, self._monitor.state())
        som._sync()
        return som

    # ----------------------------------------------------------------------------- state
    @property
    def w(self) -> np.ndarray:
        """(N, D) positions of the neurons in input space (read-only view; assign to set)."""
        return _read_only(self._w)

    @w.setter
    def w(self, value: np.ndarray) -> None:
        w = self._checked("w", value, self._w.shape)
        self._input_box.check("w", w)
        self._w = w
        self._sync()

    @property
    def theta(self) -> np.ndarray:
        """(N, J) joint angles of the neurons, rad (read-only view; assign to set)."""
        return _read_only(self._th)

    @theta.setter
    def theta(self, value: np.ndarray) -> None:
        self._th = self._checked("theta", value, self._th.shape)

    @property
    def A(self) -> np.ndarray:
        """(N, J, D) local linear maps, rad per input unit (read-only view; assign to set)."""
        return _read_only(self._A)

    @A.setter
    def A(self, value: np.ndarray) -> None:
        a = self._checked("A", value, self._A.shape)
        joint_span = (self.upper - self.lower)[:, None]  # (J, 1)
        limit = A_LIMIT * joint_span / (self.input_high - self.input_low)  # (J, D)
        if not np.all(np.abs(a) <= limit):
            raise ValueError(
                f"A has entries up to {np.abs(a).max():.3g}, beyond {A_LIMIT:g} joint spans per "
                "input span, which no trial can teach; the values are damaged"
            )
        self._A = a

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
        return self.lower.shape[0]

    @property
    def n_neurons(self) -> int:
        return math.prod(self.lattice)

    def _sync(self) -> None:
        """Derived data: |w_r|² for the winner search, parameters for the current t."""
        self._w2 = np.einsum("nd,nd->n", self._w, self._w)  # (N,)
        if self._pruned:  # bounding spheres of the lattice blocks, for the winner search
            kernels.refresh_blocks(self._w, self._shape, self._block_centre, self._block_radius)
        self._params_t = -1
        self._version += 1  # w changed outside learn(): forget the remembered winner
        self._last_winner: tuple[bytes, int, int] = (b"", -1, -1)

    def params(self) -> tuple[float, float, float, float, float]:
        """ε, σ, ε', σ' and the exploration std at t = trials learned so far."""
        t, T = self.t, self.t_max
        if self.monitor is None and t > T:
            t = T  # the floors: the same values from t_max on
        if self._params_t != t:
            frac = min(t, T) / T if self.monitor is None else self.monitor.fraction(t, T)
            self._params = tuple(
                s.at(frac)
                for s in (self.eps, self.sigma, self.eps_out, self.sigma_out, self.explore)
            )
            self._params_t = t
            self._tables = None  # the compiled path's weight tables of these widths
        return self._params

    def _winner(self, u: np.ndarray) -> int:
        """argmin_r |u − w_r|² = argmin_r |w_r|² − 2 w_r·u."""
        if self._pruned:
            return kernels.winner_pruned(
                self._w, self._w2, u, self._shape, self._block_centre, self._block_radius
            )
        if self.kernel == "numba":
            return kernels.winner(self._w, self._w2, u)
        return int((self._w2 - 2.0 * (self._w @ u)).argmin())

    def _remembered_winner(self, u: np.ndarray) -> int:
        """The winner the last coarse move found for target u if w has not changed since,
        else −1."""
        memo = self._last_winner
        return memo[2] if memo[1] == self._version and memo[0] == u.tobytes() else -1

    # ----------------------------------------------------------------------------- acting
    def reset(self) -> None:
        """Forget the previous command; the next ``act`` must be a coarse one."""
        self._u: np.ndarray | None = None  # target of the current moves
        self._cmd: np.ndarray | None = None  # last command
        self._abar: np.ndarray | None = None  # (J, D) averaged A for the fine moves
        self._v: np.ndarray | None = None  # position sensed before the last fine command
        self._cmd_before: np.ndarray | None = None  # command before the last fine one
        self._seen_cmd: np.ndarray | None = None  # with recover: last command whose marker ...
        self._seen_v: np.ndarray | None = None  # ... both cameras saw, and where

    def _vector(self, name: str, x: np.ndarray) -> np.ndarray:
        """x as a finite (D,) float array in the input box, else ValueError saying what is
        wrong."""
        a = np.asarray(x, dtype=float)
        if not (a.shape == (self.input_dim,) and math.isfinite(a @ a)):
            check_pixels(name, a, self.input_dim)  # raises for a wrong shape or NaN, naming it
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

    def _clip(self, theta: np.ndarray) -> np.ndarray:
        return np.minimum(np.maximum(theta, self.lower), self.upper)

    def _coarse(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unclipped coarse output (J,) and averaged A (J, D) for target u."""
        if self.kernel == "numba":
            _, table, r2 = self._kernel_tables()  # σ' and its cut-off, kept until t moves them
            s = self._winner(u)
            theta, abar = np.empty(self.n_joints), np.empty((self.n_joints, self.input_dim))
            kernels.coarse(s, u, self._w, self._th, self._A, table, r2, self._shape, theta, abar)
            self._last_winner = (u.tobytes(), self._version, s)
            return theta, abar
        sigma_out = self.params()[3]
        r2 = self._grid.cutoff_radius2(sigma_out) if self.averaging == "neighbourhood" else 0
        s = self._winner(u)
        self._last_winner = (u.tobytes(), self._version, s)
        if r2 > 0:
            box, g = self._grid.neighbours(s, sigma_out)
            if g.size > 1:
                K, (_, J, D) = g.size, self._A.shape
                gn = g.ravel() / g.sum()  # (K,) the box's neurons, C order
                a_k = self._grid.view(self._A, box).reshape(K, J * D)  # (K, J·D)
                du = gn[:, None] * (u - self._grid.view(self._w, box).reshape(K, D))  # (K, D)
                theta = gn @ self._grid.view(self._th, box).reshape(K, J)
                theta += np.einsum("kjd,kd->j", a_k.reshape(K, J, D), du)
                return theta, (gn @ a_k).reshape(J, D)
        a = self._A[s]
        return self._th[s] + a @ (u - self._w[s]), a.copy()

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
                self._seen_cmd = self._seen_v = None
            else:
                recovery.remember_seen(self, v)
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
        if not self.recover:
            return None
        return recovery.recovery_move(self, u, attempt)

    def _local_abar(self, u: np.ndarray) -> np.ndarray:
        """Ā (J, D) of the local fit at target u (``learners/som/local_fit.py``)."""
        s = self._remembered_winner(u)
        return local_abar(self._grid, s if s >= 0 else self._winner(u), u, self._w, self._A)

    def act_batch(self, U: np.ndarray) -> np.ndarray:
        """Coarse commands for many targets: (M, D) -> (M, J), the same as ``act`` row by row.

        Does not touch the fine-move memory. Raises ValueError for a wrong shape or NaN/inf.
        """
        U = np.asarray(U, dtype=float)
        if U.ndim != 2 or U.shape[1] != self.input_dim:
            raise ValueError(f"U must have shape (M, {self.input_dim}), got {U.shape}")
        if not np.all(np.isfinite(U)):
            raise ValueError("U contains NaN or inf; pass sensed pixels of visible targets")
        self._input_box.check("U", U)
        out = np.empty((len(U), self.n_joints))
        for i in range(0, len(U), _BATCH_BLOCK):
            out[i : i + _BATCH_BLOCK] = self._coarse_batch(U[i : i + _BATCH_BLOCK])
        return out

    def _coarse_batch(self, U: np.ndarray) -> np.ndarray:
        s = (self._w2[None, :] - 2.0 * (U @ self._w.T)).argmin(1)  # (M,)
        return self._protocol.coarse_batch(self, U, s)

    # ----------------------------------------------------------------------------- learning
    def learn(self, u: Array, theta0: Array, v0: Array, theta1: Array, v1: Array) -> bool:
        """One training trial: target u, coarse command θ0 -> sensed v0, fine θ1 -> sensed v1.

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
        D, J = self.input_dim, self.n_joints
        u, v0, v1 = np.asarray(u, dtype=float), np.asarray(v0, dtype=float), np.asarray(v1, float)
        theta0, theta1 = np.asarray(theta0, dtype=float), np.asarray(theta1, dtype=float)
        fast_ok = u.shape == (D,) and theta0.shape == theta1.shape == (J,)
        shapes_ok = fast_ok and v0.shape == (D,) == v1.shape
        if shapes_ok:
            learned = self._protocol.learn_compiled(self, (u, theta0, v0, theta1, v1))
            if learned is not None:
                return learned  # else no compiled path, or an input is wrong: see below
            self._check_trial(u, theta0, v0, theta1, v1)
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
        if self._monitor is not None:
            e = u - v0  # the coarse error: the fine move hides a shift of the images
            if self._monitor.observe(self.t, self.t_max, math.sqrt(float(e @ e))):
                self._params_t = -1  # a re-adaptation starts: the schedules run back
        s = self._remembered_winner(u)  # found by the coarse act for this target
        if s < 0:
            s = self._winner(u)
        self._version += 1
        self._protocol.learn(self, s, (u, theta0, v0, theta1, v1), dv / dv2)
        self.t += 1
        return True

    # ----------------------------------------------------------------------------- persistence
    _MEMORY = ("_u", "_cmd", "_abar", "_v", "_cmd_before", "_seen_cmd", "_seen_v")

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
            "w": self._w,
            "theta": self._th,
            "A": self._A,
            "joint_lower": self.lower,
            "joint_upper": self.upper,
            "input_low": self.input_low,
            "input_high": self.input_high,
        }
        memory = {k: getattr(self, k) for k in self._MEMORY}  # copies: the kernels write in place
        arrays.update({k: m.copy() for k, m in memory.items() if m is not None})
        return config, arrays

    @classmethod
    def load(cls, path: str | os.PathLike, kernel: str = "auto") -> VisuomotorSOM:
        """Read a map written by :meth:`save`; ``kernel`` as for the constructor.

        Raises:
            CheckpointError: missing, damaged or truncated file, another kind of state, another
                format version, or contents that do not fit together.
        """
        entries, arrays = load_npz(path, KIND, FORMAT_VERSION)
        try:
            _check_state(entries)
            config = SOMConfig.from_dict(entries)
            state = entries["rng_state"]
            bit_generator = getattr(np.random, state["bit_generator"])()
            bit_generator.state = state
            w = arrays["w"]  # the arrays' sizes before the lattice's: no huge allocation
            if w.shape != (math.prod(config.lattice), config.input_dim):
                raise CheckpointError(
                    f"{path}: array 'w' is {w.shape}, the stored lattice {config.lattice} and "
                    f"input_dim {config.input_dim} need ({math.prod(config.lattice)}, "
                    f"{config.input_dim}); the file is damaged or foreign"
                )
            som = cls(
                arrays["joint_lower"], arrays["joint_upper"], config, rng=0,
                input_low=arrays["input_low"], input_high=arrays["input_high"], kernel=kernel,
            )  # fmt: skip
            for name in ("w", "theta", "A"):
                stored, shape = arrays[name], getattr(som, name).shape
                if stored.shape != shape or stored.dtype != np.float64:
                    raise CheckpointError(
                        f"{path}: array {name!r} is {stored.dtype} {stored.shape}, the stored "
                        f"configuration needs float64 {shape}; the file is damaged or foreign"
                    )
                setattr(som, name, stored)  # copies, checks finiteness, refreshes caches
            if not np.all((som.lower <= som.theta) & (som.theta <= som.upper)):
                raise ValueError("theta lies outside the stored joint ranges")
            som.t = entries["t"]
            som.skipped = dict(entries["skipped"])
            if som.monitor is not None:
                som._monitor = ErrorMonitor(som.monitor.params, entries["continual_state"])
            som.rng = np.random.Generator(bit_generator)
            J, D = som.n_joints, som.input_dim
            shapes = {"_u": (D,), "_cmd": (J,), "_abar": (J, D), "_v": (D,), "_cmd_before": (J,),
                      "_seen_cmd": (J,), "_seen_v": (D,)}  # fmt: skip
            for k in cls._MEMORY:
                memory = arrays.get(k)
                if memory is not None and (memory.shape != shapes[k] or memory.dtype != float):
                    raise ValueError(f"{k} is {memory.dtype} {memory.shape}, not {shapes[k]}")
                check_finite(**{k: 0.0 if memory is None else memory})
                setattr(som, k, None if memory is None else memory.copy())
            som._sync()
        except CheckpointError:
            raise
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            raise CheckpointError(
                f"{path}: incomplete or inconsistent VisuomotorSOM checkpoint ({exc!r}); "
                "restore it from a copy or retrain"
            ) from exc
        return som
