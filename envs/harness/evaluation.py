"""Held-out evaluation of a controller on a reach env: errors after each move, every trial counted.

A trial stops when a marker is not seen (the controller cannot correct from a position it did not
see), unless the controller recovers (``Controller.recovers``; its extra moves are counted). The
error after every later move of a stopped trial is the error where it stopped: those values are
carried forward, and every mean, median and percentile counts all trials. A trial whose
target was not seen makes no move and keeps the error of its start pose.
On a grasp env (which reports ``info["orientation_error"]``) the hand's orientation errors are
carried forward the same way.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from envs.harness.trials import Trial, run_trial
from learners.base import Controller

#: The high percentile reported beside mean and median.
PERCENTILE = 95.0
MM_PER_M = 1e3
#: The grasp task's tail: a trial ends off when over either bound (m, rad: 1 mm or 1°).
TAIL_BOUNDS = (1e-3, float(np.radians(1.0)))


@dataclass
class Evaluation:
    """Errors of n trials after move k (column 0 coarse, then fine moves), carried forward from
    where a trial stopped, so every entry is finite."""

    distances: np.ndarray  # (n, moves) m
    pixel_errors: np.ndarray  # (n, moves) px
    target_pos: np.ndarray  # (n, 3) world m
    reached: np.ndarray  # (n, 3) world m, where the arm ended (the start pose if it never moved)
    reach: float  # m
    seconds_per_query: float  # controller time per act() call
    moves_made: np.ndarray | None = None  # (n,) int, moves made before a trial stopped
    #: (n,) int, recovery moves of each trial; None: the controller did not recover (the
    #: summary then has no recovery entries)
    recovery_moves: np.ndarray | None = None
    orientation_errors: np.ndarray | None = None  # (n, moves) rad; grasp envs only

    def __post_init__(self) -> None:
        if self.moves_made is None:
            self.moves_made = np.full(len(self.distances), self.moves)

    @property
    def moves(self) -> int:
        return self.distances.shape[1]

    @property
    def complete(self) -> np.ndarray:
        """(n,) bool: the trial made every move."""
        return self.moves_made >= self.moves

    def summary(self) -> dict[str, object]:
        """Per move, over all trials: mean, median and 95th percentile in mm, mean in % of reach,
        mean, median and 95th percentile in px; on a grasp env also mean, median and 95th
        percentile of the orientation error in degrees, the largest position (mm) and
        orientation (°) errors and the share of trials over 1 mm or 1° (``TAIL_BOUNDS``); the
        fraction of trials that made each
        move; the complete trials (count and fraction); with recovery, the trials that made
        recovery moves and the mean recovery moves per trial. JSON-ready."""
        mm = self.distances * MM_PER_M
        px = self.pixel_errors
        mean_m = self.distances.mean(axis=0)
        made = self.moves_made[:, None] > np.arange(self.moves)  # (n, moves)
        out = {
            "trials": len(self.distances),
            "complete_trials": int(self.complete.sum()),
            "complete_fraction": round(float(self.complete.mean()), 5),
            "made_fraction": made.mean(axis=0).round(5).tolist(),
            "mean_mm": (mean_m * MM_PER_M).round(4).tolist(),
            "median_mm": np.median(mm, axis=0).round(4).tolist(),
            "p95_mm": np.percentile(mm, PERCENTILE, axis=0).round(4).tolist(),
            "mean_percent_reach": (mean_m / self.reach * 100).round(5).tolist(),
            "mean_px": px.mean(axis=0).round(4).tolist(),
            "median_px": np.median(px, axis=0).round(4).tolist(),
            "p95_px": np.percentile(px, PERCENTILE, axis=0).round(4).tolist(),
        }
        if self.orientation_errors is not None:
            deg = np.degrees(self.orientation_errors)
            out["mean_deg"] = deg.mean(axis=0).round(5).tolist()
            out["median_deg"] = np.median(deg, axis=0).round(5).tolist()
            out["p95_deg"] = np.percentile(deg, PERCENTILE, axis=0).round(5).tolist()
            out["max_mm"] = mm.max(axis=0).round(4).tolist()
            out["max_deg"] = deg.max(axis=0).round(5).tolist()
            off = (self.distances > TAIL_BOUNDS[0]) | (self.orientation_errors > TAIL_BOUNDS[1])
            out["tail_fraction"] = off.mean(axis=0).round(5).tolist()
        out["microseconds_per_query"] = round(self.seconds_per_query * 1e6, 2)
        if self.recovery_moves is not None:
            out["recovered_trials"] = int((self.recovery_moves > 0).sum())
            out["mean_recovery_moves"] = round(float(self.recovery_moves.mean()), 5)
        return out


class Wrapped(Controller):
    """A controller that passes everything to ``inner``; subclasses add to ``act`` or
    ``reset``."""

    def __init__(self, inner: Controller) -> None:
        self.inner = inner

    @property
    def fine_moves_need_sight(self) -> bool:
        return self.inner.fine_moves_need_sight

    @property
    def recovers(self) -> bool:
        return self.inner.recovers

    def recovery_move(self, u, attempt):
        return self.inner.recovery_move(u, attempt)

    def act(self, u, v=None, explore=False):
        return self.inner.act(u, v, explore=True) if explore else self.inner.act(u, v)

    def reset(self) -> None:
        self.inner.reset()


class Ticking(Wrapped):
    """``inner`` that calls ``tick()`` (e.g. a progress bar's ``update``) as each trial starts."""

    def __init__(self, inner: Controller, tick: Callable[[], object]) -> None:
        super().__init__(inner)
        self._tick = tick

    def reset(self) -> None:
        self._tick()
        self.inner.reset()


class _TimedController(Wrapped):
    """Wraps a controller to time its act() calls."""

    def __init__(self, inner: Controller) -> None:
        super().__init__(inner)
        self.seconds, self.calls = 0.0, 0

    def act(self, u, v=None, explore=False):
        start = time.perf_counter()
        out = super().act(u, v, explore)
        self.seconds += time.perf_counter() - start
        self.calls += 1
        return out


def carried_forward(trial: Trial, moves: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distances (moves,) m and pixel errors (moves,) px after each move, and where the arm
    ended (3,) m; after the trial stopped, the values where it stopped (before the coarse move
    if it never moved)."""
    distances = [trial.start_distance, *trial.distances]
    pixels = [trial.start_pixel_error, *trial.pixel_errors]
    made = len(trial.distances)
    last = [min(k + 1, made) for k in range(moves)]  # index into the lists above
    ended = trial.reached[-1] if trial.reached else trial.start_pos
    return np.take(distances, last), np.take(pixels, last), np.asarray(ended, dtype=float)


def carried_orientation(trial: Trial, moves: int) -> np.ndarray:
    """Orientation errors (moves,) rad after each move of a pose-env trial, carried forward
    from where it stopped as :func:`carried_forward` carries the distances."""
    errors = [trial.start_orientation_error, *trial.orientation_errors]
    made = len(trial.orientation_errors)
    return np.take(errors, [min(k + 1, made) for k in range(moves)])


def evaluate(env, controller: Controller, trials: int, fine_moves: int = 2) -> Evaluation:
    """Run ``trials`` trials (targets from the env's own seeded generator; the caller seeds it
    with ``env.reset(seed=...)``) without learning."""
    timed = _TimedController(controller)
    runs = [run_trial(env, timed, fine_moves) for _ in range(trials)]
    seconds_per_query = timed.seconds / max(timed.calls, 1)
    return evaluation_of(
        runs, fine_moves, env.unwrapped.reach, seconds_per_query, controller.recovers
    )


def evaluation_of(
    trials: Sequence[Trial], fine_moves: int, reach: float, seconds_per_query: float, recovers: bool
) -> Evaluation:
    """The :class:`Evaluation` of ``trials`` made with ``fine_moves`` fine moves each, in order
    (as :func:`evaluate` runs them, or workers their shares); ``recovers``: the controller's."""
    moves = fine_moves + 1
    n = len(trials)
    distances, pixels, reached = np.zeros((n, moves)), np.zeros((n, moves)), np.zeros((n, 3))
    orientation = np.zeros((n, moves))
    pose = False  # the env reports the hand's orientation
    for i, trial in enumerate(trials):
        distances[i], pixels[i], reached[i] = carried_forward(trial, moves)
        if np.isfinite(trial.start_orientation_error):
            pose = True
            orientation[i] = carried_orientation(trial, moves)
    return Evaluation(
        distances,
        pixels,
        np.array([trial.target_pos for trial in trials]).reshape(n, 3),
        reached,
        reach,
        seconds_per_query,
        np.array([len(trial.distances) for trial in trials], dtype=int),
        np.array([trial.recovery_moves for trial in trials], dtype=int) if recovers else None,
        orientation if pose else None,
    )
