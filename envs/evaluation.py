"""Held-out evaluation of a controller on a reach env: errors after each move."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from envs.trials import run_trial
from learners.base import Controller


@dataclass
class Evaluation:
    """Errors of n trials after move k (column 0 coarse, then fine moves); NaN where a trial
    stopped early because a marker was not visible."""

    distances: np.ndarray  # (n, moves) m
    pixel_errors: np.ndarray  # (n, moves) px
    target_pos: np.ndarray  # (n, 3) world m
    reached: np.ndarray  # (n, 3) world m, after the last move made
    reach: float  # m
    seconds_per_query: float  # controller time per act() call

    @property
    def moves(self) -> int:
        return self.distances.shape[1]

    def summary(self) -> dict[str, object]:
        """Mean errors per move in mm, % of reach and px, plus counts (JSON-ready)."""
        complete = np.all(np.isfinite(self.distances), axis=1)
        mean_m = np.nanmean(self.distances, axis=0)
        return {
            "trials": len(self.distances),
            "complete_trials": int(complete.sum()),
            "mean_mm": (mean_m * 1e3).round(4).tolist(),
            "median_mm": (np.nanmedian(self.distances, axis=0) * 1e3).round(4).tolist(),
            "mean_percent_reach": (mean_m / self.reach * 100).round(5).tolist(),
            "mean_px": np.nanmean(self.pixel_errors, axis=0).round(4).tolist(),
            "microseconds_per_query": round(self.seconds_per_query * 1e6, 2),
        }


class _TimedController(Controller):
    """Wraps a controller to time its act() calls."""

    def __init__(self, inner: Controller) -> None:
        self.inner, self.seconds, self.calls = inner, 0.0, 0
        self.protocol = getattr(inner, "protocol", "mrs")  # for run_trial

    def act(self, u, v=None):
        start = time.perf_counter()
        out = self.inner.act(u, v)
        self.seconds += time.perf_counter() - start
        self.calls += 1
        return out

    def reset(self) -> None:
        self.inner.reset()


def evaluate(env, controller: Controller, trials: int, fine_moves: int = 2) -> Evaluation:
    """Run ``trials`` trials (targets from the env's own seeded generator; the caller seeds it
    with ``env.reset(seed=...)``) without learning."""
    moves = fine_moves + 1
    distances = np.full((trials, moves), np.nan)
    pixels = np.full((trials, moves), np.nan)
    targets = np.zeros((trials, 3))
    reached = np.full((trials, 3), np.nan)
    timed = _TimedController(controller)
    for i in range(trials):
        trial = run_trial(env, timed, fine_moves)
        k = len(trial.distances)
        distances[i, :k] = trial.distances
        pixels[i, :k] = trial.pixel_errors
        targets[i] = trial.target_pos
        if trial.reached:
            reached[i] = trial.reached[-1]
    return Evaluation(
        distances,
        pixels,
        targets,
        reached,
        env.unwrapped.reach,
        timed.seconds / max(timed.calls, 1),
    )
