"""NATEnet: node allocation and topographical encoding (the NATEnet paper in the sources,
docs/reproducing.md), prestructured for differential inverse kinematics, and the path-tracking
controller that uses it.

**Network.** Node i has a centre x_i in input space (joint angles, rad), a width σ_i (rad) and an
output matrix Y_i of shape ``output_shape`` (p, q). Its activity is a_i(x) = exp(-r_i²/σ_i²),
r_i = ‖x - x_i‖, and the net outputs the normalised sum

    M(x) = Σ_i Y_i a_i(x) / Σ_i a_i(x)        (no nodes: M = 0)

computed as a softmax of -r_i²/σ_i², so it stays finite far from every centre. *Prestructured*:
the net is used as θ̇ = M(θ)·ẋ, linear in the TCP velocity ẋ, so the nodes learn only how the
inverse Jacobian varies with θ (no matrix is inverted at run time).

**Training data** are what the arm observes: K ≥ 1 small joint moves Δθ_k made at configuration x
and the TCP pose changes Δx_k they caused (position change in m, rotation vector in rad), columns of
ΔΘ (p, K) and ΔX (q, K). The net's prediction error is E = ΔΘ - M(x)·ΔX (p, K), and its
output-space error (the smallest change of M that makes the observed moves right) is

    e = E·ΔX⁺   (p, q)     (K = 1: e = E Δxᵀ/‖Δx‖², normalised LMS; K ≥ q with ΔX of full rank:
                            e = ΔΘ·ΔX⁺ - M, the error against the least-squares local inverse)

**Learning step** s (the paper's section 2), with error measure M_e = ‖E‖_F / ‖ΔΘ‖_F:

* allocate when M_e > T_e(s) = (T0 - e_f)·exp(-s/τ) + e_f and max_i a_i(x) < T_a (and fewer than
  ``max_nodes`` nodes): centre x_N = x; width σ_N = λ·min_i ‖x_N - x_i‖ (``sigma_init`` for the
  first node until a second exists); every older width is reset to λ × its nearest-centre
  distance, σ_i ← λ·min(σ_i/λ, ‖x_N - x_i‖) (the first node's σ_init is not a distance and is
  replaced by λ‖x_2 - x_1‖); then Y_N is chosen so
  that the net is right at x: with the new widths, M(x) = (S + Y_N)/(A + 1) for S = Σ a_i Y_i,
  A = Σ a_i (a_N(x) = 1), and Y_N = (A + 1)·(M_old(x) + e) - S makes M(x) = M_old(x) + e;
* otherwise the delta rule on every node: Y_i ← Y_i + η·a_i(x)·e / Σ_j a_j(x).

``fixed_grid`` builds the comparison net: centres on a regular grid, σ = λ·(smallest grid
spacing), outputs zero, allocation off (delta rule only).

Where the paper is ambiguous: its delta rule reads Δy_i = η·a_i(x)·e; here the step is divided
by Σa, which makes it the gradient of the normalised output. The paper gives a new node the
desired output y*; here it gets the output that makes the whole net right at x, which equals y*
when no other node is active there. The error measure, the first node's width
and every numeric default are this module's choices (the paper gives none).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from learners.base import PathFollower
from learners.guards import check_finite, positive_int
from learners.persistence import CheckpointError, load_npz, save_npz

KIND, FORMAT_VERSION = "NATEnet", 1
#: Largest magnitude of an input (joint angle, rad), joint move (rad) or TCP move (m, rad): far
#: beyond any arm, and small enough that squared distances cannot overflow.
MAX_MAGNITUDE = 1e3
#: Defaults: the paper gives no numbers; these were chosen on PumaTrack-v0 (docs/decisions.md).
LAMBDA = 0.87  # width factor: Platt's (1991) κ for the resource-allocating network
ETA = 0.5  # delta-rule rate
T0 = 0.9  # initial error threshold; an empty net has M_e = 1, so the first move allocates
E_F = 0.5  # final error threshold: tracking feedback tolerates 50 % error on single moves
TAU = 2000.0  # threshold decay, learning steps (20 paths of 100 moves)
T_A = 0.5  # activity threshold
MAX_NODES = 400  # node budget
SIGMA_INIT = 0.5  # rad: width of the first node, which has no neighbour to measure


@dataclass(frozen=True)
class LearnResult:
    """What one learning step did: ``allocated`` a node or not, and the error measure M_e."""

    allocated: bool
    error: float


def _finite(name: str, a: np.ndarray) -> None:
    if not np.isfinite(a).all():
        raise ValueError(f"{name} contains NaN or inf; pass finite joint angles and TCP moves")
    if a.size and np.abs(a).max() > MAX_MAGNITUDE:
        raise ValueError(
            f"{name} holds {np.abs(a).max():g}, beyond {MAX_MAGNITUDE:g} (rad or m); pass joint "
            "angles and moves in radians and metres"
        )


class NATEnet:
    """Gaussian RBF net with error-driven node allocation (module doc gives every formula).

    Args:
        input_dim: d, length of x (6 joint angles; 5 when θ6, which does not change the base-frame
            Jacobian, is left out).
        output_shape: (p, q) of each node's matrix, (6, 6) for θ̇ = M ẋ.
        lam: λ, width factor (σ_N = λ·nearest-centre distance); small λ → nearest-neighbour
            lookup, large λ → broad overlap.
        eta: η, delta-rule learning rate (0 < η ≤ 1 is stable).
        T0, e_f, tau: error threshold T_e(s) = (T0 - e_f)·exp(-s/τ) + e_f (dimensionless M_e).
        T_a: activity threshold in (0, 1]: no allocation where a node is this active already.
        max_nodes: node budget; allocation stops when it is used up.
        sigma_init: width of the first node (units of x).
        allocate: False disables allocation (fixed nets).
    """

    def __init__(
        self,
        input_dim: int = 6,
        output_shape: Sequence[int] = (6, 6),
        lam: float = LAMBDA,
        eta: float = ETA,
        T0: float = T0,
        e_f: float = E_F,
        tau: float = TAU,
        T_a: float = T_A,
        max_nodes: int = MAX_NODES,
        sigma_init: float = SIGMA_INIT,
        allocate: bool = True,
    ) -> None:
        check_finite(lam=lam, eta=eta, T0=T0, e_f=e_f, tau=tau, T_a=T_a, sigma_init=sigma_init)
        input_dim, max_nodes = (
            positive_int("input_dim", input_dim),
            positive_int("max_nodes", max_nodes),
        )
        output_shape = tuple(positive_int("output_shape", n) for n in output_shape)
        checks = {
            "input_dim": input_dim >= 1,
            "lam": lam > 0,
            "eta": eta > 0,
            "tau": tau > 0,
            "T_a": 0 < T_a <= 1,
            "e_f": 0 <= e_f <= T0,
            "max_nodes": max_nodes >= 1,
            "sigma_init": sigma_init > 0,
            "output_shape": len(output_shape) == 2,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(
                f"invalid NATEnet arguments {bad}: need input_dim ≥ 1, lam, eta, tau, sigma_init "
                "> 0, 0 < T_a ≤ 1, 0 ≤ e_f ≤ T0, max_nodes ≥ 1 and a 2-D output_shape"
            )
        self.input_dim, self.output_shape = int(input_dim), tuple(int(n) for n in output_shape)
        self.lam, self.eta, self.tau = float(lam), float(eta), float(tau)
        self.T0, self.e_f, self.T_a = float(T0), float(e_f), float(T_a)
        self.max_nodes, self.sigma_init = int(max_nodes), float(sigma_init)
        self.allocate = bool(allocate)
        self.centres = np.empty((0, self.input_dim))  # (N, d)
        self.widths = np.empty(0)  # (N,)
        self.outputs = np.empty((0, *self.output_shape))  # (N, p, q)
        self.steps = 0  # learning steps s

    # -- construction ------------------------------------------------------------------------
    @classmethod
    def fixed_grid(
        cls, lower: np.ndarray, upper: np.ndarray, counts: Sequence[int], **kwargs
    ) -> NATEnet:
        """A net with prod(counts) centres on a regular grid over [lower, upper], no allocation.

        Widths are λ·(smallest grid spacing), the allocation rule's width for a regular grid;
        an axis with count 1 sits at the middle of its range. Other kwargs as the constructor.
        """
        lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
        grid_counts = np.asarray(counts, dtype=int)
        if not (lower.shape == upper.shape == grid_counts.shape) or np.any(grid_counts < 1):
            raise ValueError(
                "lower, upper and grid_counts need one entry per input dimension, grid_counts ≥ 1"
            )
        axes = [
            np.linspace(lo, hi, n) if n > 1 else np.array([(lo + hi) / 2])
            for lo, hi, n in zip(lower, upper, grid_counts, strict=True)
        ]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(grid_counts))
        kwargs.update(input_dim=len(grid_counts), max_nodes=max(len(grid), 1), allocate=False)
        net = cls(**kwargs)
        spacing = ((upper - lower) / np.maximum(grid_counts - 1, 1))[grid_counts > 1]
        sigma = net.lam * spacing.min() if spacing.size else net.sigma_init
        net.centres, net.widths = grid, np.full(len(grid), sigma)
        net.outputs = np.zeros((len(grid), *net.output_shape))
        return net

    @property
    def n_nodes(self) -> int:
        return len(self.centres)

    # -- evaluation --------------------------------------------------------------------------
    def _check_input(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.shape[-1:] != (self.input_dim,):
            raise ValueError(f"input must have shape (..., {self.input_dim}), got {x.shape}")
        _finite("input", x)
        return x

    def _exponents(self, x: np.ndarray) -> np.ndarray:
        diff = x[..., None, :] - self.centres  # (..., N, d)
        return -np.einsum("...nd,...nd->...n", diff, diff) / self.widths**2

    def _weights(self, x: np.ndarray) -> np.ndarray:
        z = self._exponents(x)
        z = np.exp(z - z.max(axis=-1, keepdims=True))
        return z / z.sum(axis=-1, keepdims=True)

    def activities(self, x: np.ndarray) -> np.ndarray:
        """a_i(x) for inputs (..., d) -> (..., N)."""
        return np.exp(self._exponents(self._check_input(x)))

    def weights(self, x: np.ndarray) -> np.ndarray:
        """Normalised activities a_i / Σ a (..., N), computed stably as a softmax."""
        return self._weights(self._check_input(x))

    def predict(self, x: np.ndarray) -> np.ndarray:
        """M(x): inputs (..., d) -> (..., p, q); zeros while the net has no node."""
        x = self._check_input(x)
        if self.n_nodes == 0:
            return np.zeros((*x.shape[:-1], *self.output_shape))
        flat = self._weights(x) @ self.outputs.reshape(self.n_nodes, -1)  # (..., p·q)
        return flat.reshape(*x.shape[:-1], *self.output_shape)

    def __call__(self, x: np.ndarray, xdot: np.ndarray) -> np.ndarray:
        """θ̇ = M(x)·ẋ: x (d,), ẋ (q,) -> (p,)."""
        return self.predict(x) @ np.asarray(xdot, dtype=float)

    def error_threshold(self, s: float | None = None) -> float:
        """T_e(s) = (T0 - e_f)·exp(-s/τ) + e_f at learning step s (default: the current one)."""
        s = self.steps if s is None else s
        return (self.T0 - self.e_f) * np.exp(-s / self.tau) + self.e_f

    # -- learning ----------------------------------------------------------------------------
    def learn(self, x: np.ndarray, dtheta: np.ndarray, dx: np.ndarray) -> LearnResult:
        """One learning step from K observed moves at x (module doc).

        Args:
            x: input (d,), the configuration where the moves were made.
            dtheta: joint moves (K, p) or (p,), rad. dx: the TCP moves they caused (K, q) or
                (q,): position change (m) and rotation vector (rad).
        Raises:
            ValueError: wrong shapes, NaN/inf anywhere, or no TCP motion; the net is unchanged.
        """
        x = self._check_input(x)
        p, q = self.output_shape
        dtheta, dx = np.atleast_2d(dtheta).astype(float), np.atleast_2d(dx).astype(float)
        if x.shape != (self.input_dim,) or dtheta.shape[1:] != (p,) or dx.shape != (len(dtheta), q):
            raise ValueError(
                f"learn needs x ({self.input_dim},), dtheta (K, {p}) and dx (K, {q}); got "
                f"{x.shape}, {dtheta.shape}, {dx.shape}"
            )
        _finite("dtheta", dtheta)
        _finite("dx", dx)
        if not np.any(dx):
            raise ValueError("dx is all zero: the moves must change the TCP pose to teach the net")
        M = self.predict(x)  # (p, q)
        E = dtheta.T - M @ dx.T  # (p, K)
        correction = E @ np.linalg.pinv(dx.T)  # (p, q) output-space error e
        error = float(np.linalg.norm(E) / max(np.linalg.norm(dtheta), np.finfo(float).tiny))
        threshold = self.error_threshold()  # T_e(s) for this step, s = steps done before it
        self.steps += 1
        quiet = self.n_nodes == 0 or self.activities(x).max() < self.T_a
        room = self.allocate and self.n_nodes < self.max_nodes
        if room and quiet and error > threshold:
            self._allocate(x, M + correction)
            return LearnResult(True, error)
        if self.n_nodes:
            w = self._weights(x)  # (N,)
            self.outputs += self.eta * w[:, None, None] * correction
        return LearnResult(False, error)

    def _allocate(self, x: np.ndarray, target: np.ndarray) -> None:
        """Add a node at x whose output makes M(x) = target (module doc)."""
        if self.n_nodes == 0:
            sigma = self.sigma_init
        else:
            dist = np.linalg.norm(self.centres - x, axis=-1)  # (N,)
            sigma = self.lam * dist.min()
            # σ_i/λ is node i's nearest distance so far; the first node has none (σ_init).
            nearest = self.widths / self.lam if self.n_nodes > 1 else np.full(1, np.inf)
            self.widths = self.lam * np.minimum(nearest, dist)
        a = self.activities(x)  # (N,) with the reset widths
        S = np.tensordot(a, self.outputs, axes=(0, 0))  # (p, q)
        self.centres = np.vstack([self.centres, x])
        self.widths = np.append(self.widths, sigma)
        self.outputs = np.concatenate([self.outputs, ((a.sum() + 1.0) * target - S)[None]])

    # -- persistence -------------------------------------------------------------------------
    def config(self) -> dict:
        return {
            "input_dim": self.input_dim,
            "output_shape": list(self.output_shape),
            "lam": self.lam,
            "eta": self.eta,
            "T0": self.T0,
            "e_f": self.e_f,
            "tau": self.tau,
            "T_a": self.T_a,
            "max_nodes": self.max_nodes,
            "sigma_init": self.sigma_init,
            "allocate": self.allocate,
        }

    def save(self, path: str | os.PathLike) -> Path:
        """Write the net atomically (``learners.persistence``, kind "NATEnet")."""
        arrays = {
            "centres": self.centres,
            "widths": self.widths,
            "outputs": self.outputs,
            "steps": np.array(self.steps),
        }
        return save_npz(path, KIND, FORMAT_VERSION, self.config(), arrays)

    @classmethod
    def load(cls, path: str | os.PathLike) -> NATEnet:
        """Read a net written by :meth:`save`; raises ``CheckpointError`` on a bad file."""
        config, arrays = load_npz(path, KIND, FORMAT_VERSION)
        try:
            net = cls(**config)
            centres, widths = arrays["centres"], arrays["widths"]
            outputs, steps = arrays["outputs"], arrays["steps"]
            n = len(centres)
            shapes = {
                "centres": (centres, (n, net.input_dim)),
                "widths": (widths, (n,)),
                "outputs": (outputs, (n, *net.output_shape)),
            }
            for name, (a, shape) in shapes.items():
                if a.shape != shape or a.dtype != np.float64:
                    raise ValueError(f"{name} is {a.dtype} {a.shape}, the net needs {shape}")
                check_finite(**{name: a})
            if n > net.max_nodes or not np.all(widths > 0):
                raise ValueError(f"{n} nodes (budget {net.max_nodes}) or a width <= 0")
            if steps.shape != () or steps.dtype.kind not in "iu" or steps < 0:
                raise ValueError(f"steps is {steps!r}, not a count")
        except (KeyError, TypeError, ValueError) as exc:
            raise CheckpointError(
                f"{path}: incomplete or inconsistent NATEnet checkpoint ({exc}); restore it "
                "from a copy or retrain"
            ) from exc
        net.centres, net.widths, net.outputs, net.steps = centres, widths, outputs, int(steps)
        return net


def grid_counts(lower: np.ndarray, upper: np.ndarray, n_nodes: int) -> np.ndarray:
    """Points per axis of a grid over [lower, upper] with at most ``n_nodes`` nodes: starting
    from one per axis, the axis with the widest cells (range / points) among those that still
    fit gets one more point, until no axis fits."""
    span = np.asarray(upper, dtype=float) - np.asarray(lower, dtype=float)
    counts = np.ones(len(span), dtype=int)
    while True:
        cells = span / counts
        fits = np.prod(counts) // counts * (counts + 1) <= n_nodes  # (d,) product after +1
        if not fits.any():
            return counts
        counts[np.argmax(np.where(fits, cells, -np.inf))] += 1


#: Default feedback gain of the tracker, per control step (1 = dead-beat).
GAIN = 1.0


class PathTracker(PathFollower):
    """Differential IK tracking: θ̇ = M(θ)·(ẋ_d + K·(x_d - x)), one control step at a time.

    The pose error stacks the position error (m) and the orientation error as a rotation vector
    (rad, world frame). The env reports the *next* path pose x_d(k+1) and the desired velocity
    ẋ_d; with the current desired pose x_d(k) = x_d(k+1) - ẋ_d·dt the step is

        Δθ = M(θ)·(ẋ_d·dt + K·(x_d(k) - x)) = M(θ)·(K·(x_d(k+1) - x) + (1 - K)·ẋ_d·dt),

    so K = 1 (dead-beat, the default) heads straight for the next path point. ``inverse(theta)``
    is M (6, 6): a trained :class:`NATEnet` (:meth:`from_net`) or the exact inverse Jacobian.

    Args:
        inverse: θ (6,) -> M (6, 6). gain: K per control step, in (0, 1].
    """

    def __init__(self, inverse: Callable[[np.ndarray], np.ndarray], gain: float = GAIN) -> None:
        if not 0 < gain <= 1:
            raise ValueError(f"gain must be in (0, 1], got {gain}")
        self.inverse, self.gain = inverse, float(gain)

    @classmethod
    def from_net(cls, net: NATEnet, gain: float = GAIN) -> PathTracker:
        """A tracker using the net on the first ``net.input_dim`` joint angles."""
        return cls(lambda theta: net.predict(np.asarray(theta)[: net.input_dim]), gain)

    def command(
        self, theta: np.ndarray, next_error: np.ndarray, twist: np.ndarray, dt: float
    ) -> np.ndarray:
        """Joint increment Δθ (6,), rad.

        Args:
            theta: joints (6,), rad. next_error: (6,) position (m) and rotation-vector (rad)
                error of the sensed pose against the next path pose. twist: desired velocity
                (6,) (m/s, rad/s); dt: control period (s).
        """
        u = self.gain * np.asarray(next_error) + (1.0 - self.gain) * np.asarray(twist) * dt
        return self.inverse(theta) @ u
