"""The hierarchical visuomotor map: the hand's position and orientation learned from the cameras.

A 3-D lattice for the object's position with a lattice for its orientation nested at every node
(Martinetz & Schulten 1990); each leaf holds joint angles and a local linear map from the
cameras' features of the three markers to the joints. ``act`` makes the coarse move and the fine
moves (with a trust region in joint space), ``learn`` one pair of moves. The equations, and
where this map follows the paper and where it departs, are in docs/map.md ("The hierarchical
map of the grasp task").
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from learners.base import Array, Learner
from learners.guards import INPUT_MARGIN, InputBox, check_finite, joint_ranges
from learners.persistence import damaged, load_npz, save_npz
from learners.pose_pixels import PIXELS, check_pose_pixels
from learners.som import stored as checked
from learners.som.hierarchical_config import HierarchicalConfig
from learners.som.lattice import Lattice

KIND = "HierarchicalSOM"
FORMAT_VERSION = 1
#: Feature rows: f = F u, p = marker 1, o = markers 2 and 3 minus marker 1.
FEATURES = np.block(
    [
        [np.eye(4), np.zeros((4, 8))],
        [-np.eye(4), np.eye(4), np.zeros((4, 4))],
        [-np.eye(4), np.zeros((4, 4)), np.eye(4)],
    ]
)  # (12, 12)
#: The w_rs start within this fraction of the image size around zero offset.
ORIENTATION_START = 0.25
#: Weight of the newest trial in the running mean C of Δf Δfᵀ that whitens the Widrow-Hoff step.
WHITEN_RATE = 0.01
#: C is regularised by this fraction of its mean eigenvalue (trace / 12) before it is inverted:
#: Δf spans only the 6 directions the joints move the markers in, so C alone is singular.
WHITEN_FLOOR = 1e-3
#: backtrack: a fine move that leaves the sensed feature error |f(u) − f(v)| more than this many
#: times the trial's best is undone (1.25-3 measured on 1 000 objects: docs/decisions.md).
BACKTRACK_GROWTH = 1.5
#: backtrack with a trust region (``trust_radius`` > 0): its threshold, chosen between 1.5 and 2
#: on validation objects (2 was better for 3 seeds × both ranges: envs/studies/pose_tail.py,
#: docs/decisions.md).
TRUST_GROWTH = 2.0
#: The trust radius's factor after a fine move that beat the trial's best (and 1/2 after an
#: undone one).
TRUST_EXPAND = 2.0


class HierarchicalSOM(Learner):
    """Position lattice with an orientation lattice nested at every node (module docstring).

    Args:
        joint_lower, joint_upper: joint ranges (J,), rad; every command is clipped into them.
        theta_init: (J,) the taught pose every θ_rs starts at, rad.
        config: the options (:class:`~learners.som.hierarchical_config.HierarchicalConfig`);
            ``options`` change single fields of it by name.
        rng: a numpy Generator or a seed; the map's only source of randomness.
    Raises:
        ValueError: one line naming a wrong option, range or start pose.
    """

    def __init__(
        self,
        joint_lower: np.ndarray,
        joint_upper: np.ndarray,
        theta_init: np.ndarray,
        config: HierarchicalConfig | None = None,
        rng: np.random.Generator | int | None = None,
        **options: Any,
    ) -> None:
        self.config = HierarchicalConfig.of(config, **options)
        self.lower, self.upper = joint_ranges(joint_lower, joint_upper)  # (J,) each
        start = np.array(theta_init, dtype=float).ravel()
        check_finite(theta_init=start)
        if start.shape != self.lower.shape or not np.all(
            (self.lower <= start) & (start <= self.upper)
        ):
            raise ValueError(
                f"theta_init {start} must have one angle per joint, inside the joint ranges"
            )
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        c = self.config
        width, height = c.image_size
        image = np.array([width, height, width, height], dtype=float)
        self._pixel_box = InputBox(np.zeros(PIXELS), np.tile(image, 3), "image")
        self._positions = Lattice(c.position_lattice)
        self._orientations = Lattice(c.orientation_lattice)
        gain = np.concatenate([np.ones(4), np.full(8, c.orientation_gain)])
        self._features_t = (gain[:, None] * FEATURES).T  # (12, 12), f = u @ this
        P, Q, J = c.n_positions, c.n_orientations, self.n_joints
        self.w_pos = self.rng.uniform(0.0, image, size=(P, 4))  # (P, 4)
        reach = ORIENTATION_START * c.orientation_gain * np.tile(image, 2)
        self.w_ori = self.rng.uniform(-reach, reach, size=(P, Q, 8))  # (P, Q, 8)
        self.theta = np.tile(start, (P, Q, 1))  # (P, Q, J)
        self.A = np.zeros((P, Q, J, PIXELS))  # (P, Q, J, 12)
        self.df_cov = np.eye(PIXELS)  # (12, 12) running mean of Δf Δfᵀ, px²
        self.t = 0
        self.skipped = {"not_visible": 0, "small_dv": 0}
        self.reset()

    # ----------------------------------------------------------------------------- structure
    @property
    def n_joints(self) -> int:
        return self.lower.shape[0]

    @property
    def lattice(self) -> tuple[int, ...]:
        """The position lattice's shape (what a training run's identity records)."""
        return self.config.position_lattice

    @property
    def n_leaves(self) -> int:
        return self.config.n_positions * self.config.n_orientations

    def params(self) -> tuple[float, float, float, float, float]:
        """ε, σ, ε', σ' and the exploration std at t = trials learned so far."""
        c = self.config
        frac = min(self.t, c.t_max) / c.t_max
        eps, sigma, eps_out, sigma_out, explore = (
            s.at(frac) for s in (c.eps, c.sigma, c.eps_out, c.sigma_out, c.explore)
        )
        return eps, sigma, eps_out, sigma_out, explore

    def features(self, u: np.ndarray) -> np.ndarray:
        """f(u) (..., 12): marker 1's pixels, then ``orientation_gain`` times markers 2 and 3
        minus marker 1."""
        return np.asarray(u, dtype=float) @ self._features_t

    def winners(self, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Position and orientation winners (M,), (M,) of features f (M, 12)."""
        p, o = f[:, :4], f[:, 4:]
        d_pos = (self.w_pos**2).sum(-1) - 2.0 * p @ self.w_pos.T  # (M, P)
        r = d_pos.argmin(axis=1)
        w = self.w_ori[r]  # (M, O, 8)
        d_ori = (w**2).sum(-1) - 2.0 * np.einsum("mod,md->mo", w, o)  # (M, O)
        return r, d_ori.argmin(axis=1)

    def centre(self, r: np.ndarray, s: np.ndarray) -> np.ndarray:
        """The leaves' centres c_rs (M, 12) in feature space."""
        return np.concatenate([self.w_pos[r], self.w_ori[r, s]], axis=-1)

    def with_fine_moves(
        self, refine: bool, backtrack: bool, trust_radius: float | None = None
    ) -> HierarchicalSOM:
        """A copy of this map whose fine moves take (or not) the Broyden step and backtrack
        (``trust_radius``: None keeps this map's); what it learned is the same (a copy), and its
        fine-move memory starts empty."""
        entries, arrays = self.state()
        options: dict[str, Any] = {"refine": refine, "backtrack": backtrack}
        if trust_radius is not None:
            options["trust_radius"] = trust_radius
        som = HierarchicalSOM(
            self.lower, self.upper, self.theta[0, 0],
            HierarchicalConfig.of(self.config, **options), rng=0,
        )  # fmt: skip
        bit_generator = type(self.rng.bit_generator)()
        bit_generator.state = entries["rng_state"]
        som._take(arrays, self.t, self.skipped, bit_generator)
        return som

    def _take(
        self, arrays: dict[str, np.ndarray], t: int, skipped: dict[str, int], bit_generator: Any
    ) -> None:
        """Take over a learned state: copies of its arrays, its counts and its generator."""
        for name in ("w_pos", "w_ori", "theta", "A", "df_cov"):
            setattr(self, name, arrays[name].copy())
        self.t, self.skipped = t, dict(skipped)
        self.rng = np.random.Generator(bit_generator)

    # ----------------------------------------------------------------------------- acting
    def reset(self) -> None:
        """Forget the previous command; the next ``act`` must be a coarse one."""
        self._abar: np.ndarray | None = None  # (J, 12) the fine moves' map, refined by them
        self._cmd: np.ndarray | None = None  # last command
        self._fv: np.ndarray | None = None  # features sensed before the last fine command
        self._cmd_before: np.ndarray | None = None  # command before the last fine one
        # backtrack: the best sighting of the trial (|f(u) − f(v)|², command, f(v)), the step
        self._best: tuple[float, np.ndarray, np.ndarray] | None = None
        self._step = 1.0  # trust_radius = 0: the step's factor; else the trust radius, rad

    @property
    def _trust(self) -> bool:
        """Whether the fine moves keep a trust region (``backtrack`` and ``trust_radius`` > 0)."""
        return self.config.backtrack and self.config.trust_radius > 0.0

    def _broyden(self, dtheta: np.ndarray, df: np.ndarray) -> None:
        """Ā += (Δθ − Ā Δf) Δf^T / |Δf|² from the last two commands and what they gave."""
        df2 = float(df @ df)
        if self.config.refine and df2 >= self.config.min_dv**2 and self._abar is not None:
            self._abar += np.outer(dtheta - self._abar @ df, df) / df2

    def _pixels(self, name: str, x: np.ndarray) -> np.ndarray:
        a = check_pose_pixels(name, x)
        self._pixel_box.check(name, a)
        return a

    def _clip(self, theta: np.ndarray) -> np.ndarray:
        return np.minimum(np.maximum(theta, self.lower), self.upper)

    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        """Coarse command for target pixels u (12,), or, given the hand's pixels v (12,) sensed
        after the previous command, the fine command θ + A_rs (f(u) − f(v)).

        Args:
            explore: add N(0, explore(t)²) rad to a fine command (training).
        Returns:
            joint command (J,), rad, clipped into the joint ranges.
        Raises:
            ValueError: u or v not (12,) finite pixels in (a margin around) the image, or a fine
                move without a coarse one since ``reset()``.
        """
        f = self.features(self._pixels("u", u))
        if v is None:
            r, s = (int(i[0]) for i in self.winners(f[None]))
            command = self.theta[r, s] + self.A[r, s] @ (f - self.centre(np.array(r), np.array(s)))
            self._abar = self.A[r, s].copy()
            self._fv = self._cmd_before = self._best = None
            self._step = self.config.trust_radius if self._trust else 1.0
        else:
            fv = self.features(self._pixels("v", v))
            if self._abar is None or self._cmd is None:
                raise ValueError("a fine move act(u, v) needs a coarse act(u) first (after reset)")
            if self._fv is not None and self._cmd_before is not None:
                self._broyden(self._cmd - self._cmd_before, fv - self._fv)
            base, f_base = self._cmd, fv
            if self.config.backtrack:
                growth = TRUST_GROWTH if self._trust else BACKTRACK_GROWTH
                error = float((f - fv) @ (f - fv))
                if self._best is None or error < self._best[0]:
                    if self._best is not None and self._trust:
                        self._step *= TRUST_EXPAND
                    self._best = (error, self._cmd, fv)
                elif error > growth**2 * self._best[0]:  # farther: from the best again
                    if self._trust:  # half the undone step's largest joint change at most
                        undone = float(np.abs(self._cmd - self._cmd_before).max())
                        self._step = min(self._step, undone)
                    _, base, f_base = self._best
                    self._step *= 0.5
            step = self._abar @ (f - f_base)
            if self._trust:  # the largest joint change at most the trust radius
                largest = float(np.abs(step).max())
                command = base + (step * (self._step / largest) if largest > self._step else step)
            else:
                command = base + self._step * step
            self._fv, self._cmd_before = f_base, base
            if explore:
                command = command + self.rng.normal(0.0, self.params()[4], self.n_joints)
        self._cmd = self._clip(command)
        return self._cmd.copy()

    def act_batch(self, U: np.ndarray) -> np.ndarray:
        """Coarse commands (M, J) for targets (M, 12), as ``act`` row by row; the fine-move
        memory is left alone."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        if U.ndim != 2 or U.shape[1] != PIXELS or not np.all(np.isfinite(U)):
            raise ValueError(f"U must be finite pixels of shape (M, {PIXELS}), got {U.shape}")
        self._pixel_box.check("U", U)
        f = self.features(U)
        r, s = self.winners(f)
        theta = self.theta[r, s] + np.einsum("mjd,md->mj", self.A[r, s], f - self.centre(r, s))
        return self._clip(theta)

    # ----------------------------------------------------------------------------- learning
    def learn(
        self, u: Array, theta0: Array, v0: Array, theta1: Array, v1: Array, coarse: bool = True
    ) -> bool:
        """One trial: target u, coarse θ0 -> sensed v0, fine θ1 -> sensed v1 (module docstring).

        ``coarse=False``: θ0 -> v0 is a later move of the same trial (fine move k -> k + 1):
        θ* = θ0 + A_rs (c_rs − f(v0)), and the input weights and t stay (module docstring,
        "Later pairs").

        Returns False (and learns nothing) when v0 or v1 holds NaN (a marker not seen) or the
        sensed change is below ``min_dv``. Raises ValueError for a wrong shape or a NaN in u,
        θ0 or θ1.
        """
        f = self.features(self._pixels("u", u))
        theta0 = np.asarray(theta0, dtype=float)
        theta1 = np.asarray(theta1, dtype=float)
        for name, th in (("theta0", theta0), ("theta1", theta1)):
            if th.shape != self.lower.shape or not np.all(np.isfinite(th)):
                raise ValueError(f"{name} must be {self.lower.shape} finite joint angles, got {th}")
        v0, v1 = np.asarray(v0, dtype=float), np.asarray(v1, dtype=float)
        if v0.shape != (PIXELS,) or v1.shape != (PIXELS,):
            raise ValueError(f"v0 and v1 must have shape ({PIXELS},), got {v0.shape}, {v1.shape}")
        if not (np.all(np.isfinite(v0)) and np.all(np.isfinite(v1))):
            self.skipped["not_visible"] += 1
            return False
        self._pixel_box.check("v0", v0)
        self._pixel_box.check("v1", v1)
        f0, f1 = self.features(v0), self.features(v1)
        df = f1 - f0
        df2 = float(df @ df)
        if df2 < self.config.min_dv**2:
            self.skipped["small_dv"] += 1
            return False
        r, s = (int(i[0]) for i in self.winners(f[None]))
        centre = self.centre(np.array([r]), np.array([s]))[0]  # (12,) before the update
        a = self.A[r, s]  # (J, 12)
        if coarse:
            theta_star = self.theta[r, s] + a @ (f - f0)
        else:  # the pair's first move, moved to the winner's centre along A_rs
            theta_star = theta0 + a @ (centre - f0)
        self.df_cov += WHITEN_RATE * (np.outer(df, df) - self.df_cov)
        floor = WHITEN_FLOOR * np.trace(self.df_cov) / PIXELS
        g = np.linalg.solve(self.df_cov + floor * np.eye(PIXELS), df)  # (12,) C⁻¹ Δf
        a_star = a + np.outer(theta1 - theta0 - a @ df, g) / (g @ df)
        eps, sigma, eps_out, sigma_out, _ = self.params()
        if coarse:
            box, h = self._positions.neighbours(r, sigma)
            view = self._positions.view(self.w_pos, box)
            view += (eps * h)[..., None] * (f[:4] - view)
            view, h = self._box(self.w_ori, r, s, sigma)
            view += (eps * h)[..., None] * (f[4:] - view)
        view, h = self._box(self.theta, r, s, sigma_out)
        if self.config.transport:  # θ* moved to every leaf's own (new) centre along A*
            box_p = self._boxes(r, s, sigma_out)[0]
            w_pos = self._positions.view(self.w_pos, box_p)  # (*box_p, 4)
            w_ori = self._box(self.w_ori, r, s, sigma_out)[0]  # (*box_p, *box_o, 8)
            w_pos = w_pos.reshape(w_pos.shape[:-1] + (1,) * (w_ori.ndim - w_pos.ndim) + (4,))
            shift = (
                np.concatenate([np.broadcast_to(w_pos, (*w_ori.shape[:-1], 4)), w_ori], axis=-1)
                - centre
            )  # (*box_p, *box_o, 12)
            theta_star = theta_star + shift @ a_star.T  # (*box_p, *box_o, J)
        view += (eps_out * h)[..., None] * (theta_star - view)
        view, h = self._box(self.A, r, s, sigma_out)
        view += (eps_out * h)[..., None, None] * (a_star - view)
        np.clip(self.theta, self.lower, self.upper, out=self.theta)
        self.t += int(coarse)
        return True

    def _boxes(self, r: int, s: int, sigma: float) -> tuple[tuple[slice, ...], tuple[slice, ...]]:
        """The neighbourhood boxes of width σ around r (position) and s (orientation)."""
        return self._positions.neighbours(r, sigma)[0], self._orientations.neighbours(s, sigma)[0]

    def _box(
        self, array: np.ndarray, r: int, s: int, sigma: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The leaves of (P, O, ...) ``array`` in both neighbourhoods of width σ around leaf
        (r, s) as a writable view (*box_p, *box_o, ...), and their weights h_rr' h_ss'
        (*box_p, *box_o)."""
        box_p, h_p = self._positions.neighbours(r, sigma)
        box_o, h_o = self._orientations.neighbours(s, sigma)
        shape = (*self._positions.shape, *self._orientations.shape, *array.shape[2:])
        return array.reshape(shape)[(*box_p, *box_o)], np.multiply.outer(h_p, h_o)

    # ----------------------------------------------------------------------------- saving
    def save(self, path: str | os.PathLike) -> Path:
        """Write the map (options, arrays, t, skip counts, generator state) atomically."""
        return save_npz(path, KIND, FORMAT_VERSION, *self.state())

    def state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """(configuration, arrays) that :meth:`save` writes; a training run's checkpoint adds
        its own entries beside them (``envs.harness.checkpoint``), and :meth:`load` reads both."""
        config = self.config.to_dict()
        config.update(t=self.t, skipped=dict(self.skipped), rng_state=self.rng.bit_generator.state)
        arrays = {
            "w_pos": self.w_pos, "w_ori": self.w_ori, "theta": self.theta, "A": self.A,
            "df_cov": self.df_cov, "joint_lower": self.lower, "joint_upper": self.upper,
        }  # fmt: skip
        return config, arrays

    @classmethod
    def load(cls, path: str | os.PathLike) -> HierarchicalSOM:
        """Read a map written by :meth:`save`.

        Raises:
            CheckpointError: a missing, damaged or foreign file, or contents that do not fit
                together (shapes, dtypes, non-finite values, values beyond where learning
                can take them: `learners/som/stored.py`).
        """
        entries, arrays = load_npz(path, KIND, FORMAT_VERSION)
        try:
            config = HierarchicalConfig.from_dict(entries)
            t, skipped = checked.counts(entries)
            rng = checked.generator(entries["rng_state"])
            lower, upper = checked.ranges(arrays, "joint_lower", "joint_upper")
            P, Q, J = config.n_positions, config.n_orientations, len(lower)
            shapes = {
                "w_pos": (P, 4), "w_ori": (P, Q, 8), "theta": (P, Q, J), "A": (P, Q, J, PIXELS),
                "df_cov": (PIXELS, PIXELS),
            }  # fmt: skip
            learned = {name: checked.array(arrays, name, shape) for name, shape in shapes.items()}
            _check_learned(learned, config, lower, upper)
            som = cls(lower, upper, learned["theta"][0, 0], config, rng=0)
            som._take(learned, t, skipped, rng.bit_generator)
        except (KeyError, TypeError, ValueError, AttributeError, IndexError, OverflowError) as exc:
            raise damaged(path, KIND, exc) from exc
        return som


def _check_learned(
    arrays: dict[str, np.ndarray], config: HierarchicalConfig, lower: np.ndarray, upper: np.ndarray
) -> None:
    """ValueError unless the learned arrays lie where learning can take them: θ in the joint
    ranges, the nodes' weights within the features of pixels in the margin around the image
    (every update moves them towards such features), A within the reach map's limit per feature
    span, and C (a running mean of Δf Δfᵀ from the identity) symmetric with a diagonal >= 0 and
    no entry beyond the square of the largest feature change."""
    checked.within("theta", arrays["theta"], lower, upper, "the stored joint ranges")
    image = np.tile(np.array(config.image_size, dtype=float), 2)  # (4,) one marker's pixels
    checked.within(
        "w_pos", arrays["w_pos"], -INPUT_MARGIN * image, (1 + INPUT_MARGIN) * image,
        "the margin around the image",
    )  # fmt: skip
    offsets = config.orientation_gain * (1 + 2 * INPUT_MARGIN) * np.tile(image, 2)  # (8,)
    checked.within("w_ori", arrays["w_ori"], -offsets, offsets, "the offsets of such pixels")
    spans = np.concatenate([image, config.orientation_gain * np.tile(image, 2)])  # (12,)
    checked.check_linear_map("A", arrays["A"], upper - lower, spans)
    cov = arrays["df_cov"]
    largest = max(1.0, 2 * config.orientation_gain) * (1 + 2 * INPUT_MARGIN) * image.max()
    if not (np.array_equal(cov, cov.T) and np.all(np.diag(cov) >= 0)):
        raise ValueError("array 'df_cov' (12, 12) is not symmetric with a diagonal >= 0")
    checked.within("df_cov", cov, -max(1.0, largest**2), max(1.0, largest**2), "its bound")
