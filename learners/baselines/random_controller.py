"""A controller that ignores what it sees: uniform random commands (a floor for comparisons)."""

from __future__ import annotations

import numpy as np

from learners.base import Controller, check_pixels


class RandomController(Controller):
    """Coarse move: a uniform random command; fine moves: the previous command plus a uniform
    step of at most ``fine_step`` rad per joint, clipped to the ranges."""

    def __init__(
        self,
        joint_lower: np.ndarray,
        joint_upper: np.ndarray,
        rng: np.random.Generator | int | None = None,
        fine_step: float = 0.05,
    ) -> None:
        self.lower = np.asarray(joint_lower, dtype=float)
        self.upper = np.asarray(joint_upper, dtype=float)
        if self.lower.shape != self.upper.shape or np.any(self.lower > self.upper):
            raise ValueError("joint_lower and joint_upper must have one shape and lower <= upper")
        self.rng = np.random.default_rng(rng)
        self.fine_step = fine_step
        self._previous: np.ndarray | None = None

    def act(self, u: np.ndarray, v: np.ndarray | None = None, explore: bool = False) -> np.ndarray:
        check_pixels("u", u)
        if v is None or self._previous is None:
            command = self.rng.uniform(self.lower, self.upper)
        else:
            step = self.rng.uniform(-self.fine_step, self.fine_step, self.lower.shape)
            command = np.clip(self._previous + step, self.lower, self.upper)
        self._previous = command
        return command.copy()

    def reset(self) -> None:
        self._previous = None
