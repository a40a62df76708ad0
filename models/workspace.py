"""Target workspaces: where reach targets are drawn, uniformly, from a numpy Generator."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


class Workspace(ABC):
    """A bounded set of world points (metres)."""

    lower: np.ndarray  # (3,) bounding box
    upper: np.ndarray  # (3,)

    @abstractmethod
    def contains(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) -> (N,) bool."""

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n points drawn uniformly from the set (rejection from the bounding box); (n, 3)."""
        out = np.empty((0, 3))
        while len(out) < n:
            cand = rng.uniform(self.lower, self.upper, size=(2 * (n - len(out)) + 8, 3))
            out = np.concatenate([out, cand[self.contains(cand)]])
        return out[:n]


@dataclass(frozen=True)
class BoxWorkspace(Workspace):
    """An axis-aligned box [lower, upper] in world coordinates."""

    lower: np.ndarray
    upper: np.ndarray

    def contains(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        return np.all((p >= self.lower) & (p <= self.upper), axis=-1)


@dataclass(frozen=True)
class ReachableWorkspace(Workspace):
    """The points an inverse kinematics maps into the joint ranges.

    ``ik(points) -> (N, J)`` joint angles (NaN where unreachable).
    """

    lower: np.ndarray
    upper: np.ndarray
    ik: Callable[[np.ndarray], np.ndarray]
    joint_lower: np.ndarray
    joint_upper: np.ndarray

    def contains(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        with np.errstate(invalid="ignore", divide="ignore"):
            q = self.ik(p)
        inside = np.all((q >= self.joint_lower) & (q <= self.joint_upper), axis=-1)
        return inside & np.all((p >= self.lower) & (p <= self.upper), axis=-1)
