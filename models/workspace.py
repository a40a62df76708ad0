"""Target workspaces: where reach targets are drawn, uniformly, from a numpy Generator."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

#: Candidates a sampling round draws for ``n`` points still missing: ``2 n + SPARE_CANDIDATES``.
SPARE_CANDIDATES = 8
REACH_MARGIN = 1e-9  # relative, on the squared reach: rounding errors are ~1e-16


class Workspace(ABC):
    """A bounded set of world points (metres)."""

    lower: np.ndarray  # (3,) bounding box
    upper: np.ndarray  # (3,)

    @abstractmethod
    def contains(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) -> (N,) bool."""

    @abstractmethod
    def contains_point(self, x: float, y: float, z: float) -> bool:
        """:meth:`contains` for one point given as Python floats (m), without array overhead."""

    @cached_property
    def _floats(self) -> tuple[list[float], list[float], list[float]]:
        """lower, upper - lower (as ``rng.uniform`` computes it) and upper, as Python floats."""
        return self.lower.tolist(), (self.upper - self.lower).tolist(), self.upper.tolist()

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n points drawn uniformly from the set (rejection from the bounding box); (n, 3).

        Each round draws ``2 m + SPARE_CANDIDATES`` candidates for the m points still missing
        and keeps those inside, in order. One point (a reach env's reset) is tested candidate by
        candidate with :meth:`contains_point` up to the first inside: the same draws from
        ``rng`` and the same point as the batch test (:meth:`contains`) would give.
        """
        if n == 1:
            return self.sample_one(rng)[None]
        out = np.empty((0, 3))
        while len(out) < n:
            cand = rng.uniform(self.lower, self.upper, size=(_round_size(n - len(out)), 3))
            out = np.concatenate([out, cand[self.contains(cand)]])
        return out[:n]

    def sample_one(self, rng: np.random.Generator) -> np.ndarray:
        """One point (3,), ``sample(rng, 1)[0]``: its rounds tested one candidate at a time.

        ``rng.uniform(lower, upper)`` is ``lower + (upper - lower) * rng.random()`` (NumPy's
        ``random_uniform``, one double per coordinate in C order); the same IEEE operations on
        Python floats give the same candidates without the cost of its broadcasting.
        """
        (x0, y0, z0), (sx, sy, sz) = self._floats[0], self._floats[1]
        contains, values = self.contains_point, 3 * _round_size(1)
        while True:
            u = rng.random(values).tolist()
            for i in range(0, values, 3):
                x, y, z = x0 + sx * u[i], y0 + sy * u[i + 1], z0 + sz * u[i + 2]
                if contains(x, y, z):
                    return np.array([x, y, z])


@dataclass(frozen=True)
class BoxWorkspace(Workspace):
    """An axis-aligned box [lower, upper] in world coordinates."""

    lower: np.ndarray
    upper: np.ndarray

    def contains(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        return np.all((p >= self.lower) & (p <= self.upper), axis=-1)

    def contains_point(self, x: float, y: float, z: float) -> bool:
        lower, _, upper = self._floats
        return _inside((x, y, z), lower, upper)


@dataclass(frozen=True)
class ReachableWorkspace(Workspace):
    """The points an inverse kinematics maps into the joint ranges.

    ``ik(points) -> (N, J)`` joint angles (NaN where unreachable); ``ik_point(x, y, z) -> (J,)``
    the same formula on Python floats (``math``), raising ValueError or ZeroDivisionError where
    it has no solution. ``reach`` (m): no point farther from the origin is reachable; the point
    test rejects those first, without the IK and its exception (a third of RIACS's box).
    """

    lower: np.ndarray
    upper: np.ndarray
    ik: Callable[[np.ndarray], np.ndarray]
    ik_point: Callable[[float, float, float], tuple[float, ...]]
    joint_lower: np.ndarray
    joint_upper: np.ndarray
    reach: float = math.inf

    def contains(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        with np.errstate(invalid="ignore", divide="ignore"):
            q = self.ik(p)
        inside = np.all((q >= self.joint_lower) & (q <= self.joint_upper), axis=-1)
        return inside & np.all((p >= self.lower) & (p <= self.upper), axis=-1)

    def contains_point(self, x: float, y: float, z: float) -> bool:
        # The cheapest test first: a sampled candidate always lies in the box, and the reach
        # rejects a third of RIACS's.
        if x * x + y * y + z * z > self._reach_squared:
            return False
        try:
            q = self.ik_point(x, y, z)
        except (ValueError, ZeroDivisionError):  # math's "no solution" (numpy's NaN)
            return False
        lower, _, upper = self._floats
        return _inside(q, *self._joint_floats) and _inside((x, y, z), lower, upper)

    @cached_property
    def _reach_squared(self) -> float:
        """m², with a relative margin far above rounding: the IK fails beyond it, and so would
        the exact test."""
        return self.reach * self.reach * (1.0 + REACH_MARGIN)

    @cached_property
    def _joint_floats(self) -> tuple[list[float], list[float]]:
        return self.joint_lower.tolist(), self.joint_upper.tolist()


def _round_size(missing: int) -> int:
    """Candidates one sampling round draws for ``missing`` points."""
    return 2 * missing + SPARE_CANDIDATES


def _inside(values, lower: list[float], upper: list[float]) -> bool:
    """lower ≤ values ≤ upper in every entry (False for NaN, like the array comparisons)."""
    for low, value, high in zip(lower, values, upper, strict=True):
        if not low <= value <= high:
            return False
    return True
