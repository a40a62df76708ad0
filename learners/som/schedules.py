"""Decaying training parameters of the Kohonen map (learning rates, widths).

Ritter, Martinetz & Schulten (1989, 1990) let every parameter x fall geometrically from x_i to
x_f over the t_max training steps:

    x(t) = x_i (x_f / x_i)^(t / t_max)

Beyond t_max the value stays at x_f (the rule would otherwise keep shrinking it): a floor, unlike
Brause's (3.3), whose γ → 0; :func:`harmonic` is a rate that satisfies (3.3).

:class:`Continual` (this project's, not in the papers) runs the schedules back when the error the
map senses rises after t_max, so that a map keeps re-adapting when the cameras or the arm change.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from learners.guards import option_number


@dataclass(frozen=True)
class Schedule:
    """x(t) = initial · (final / initial)^(min(t, t_max) / t_max).

    Args:
        initial: value at t = 0; > 0, or 0 together with ``final`` for a parameter that is off.
        final: value from t = t_max on; > 0 (or 0, see above).
    """

    initial: float
    final: float

    def __post_init__(self) -> None:
        off = self.initial == 0.0 and self.final == 0.0
        if not off and not (self.initial > 0.0 and self.final > 0.0):
            raise ValueError(
                f"a schedule needs initial > 0 and final > 0 (or both 0 to switch it off), "
                f"got initial={self.initial}, final={self.final}"
            )

    def __call__(self, t: int, t_max: int) -> float:
        """Value at step ``t`` (trials learned so far) of a run of ``t_max`` steps."""
        return self.at(min(t, t_max) / t_max)

    def at(self, frac: float) -> float:
        """Value at the fraction ``frac`` ∈ [0, 1] of the schedule."""
        if self.initial == 0.0:
            return 0.0
        return self.initial * (self.final / self.initial) ** frac

    @classmethod
    def of(cls, value: Schedule | tuple[float, float] | float) -> Schedule:
        """A schedule from a Schedule, an (initial, final) pair or one constant value."""
        if isinstance(value, Schedule):
            return value
        if isinstance(value, (int, float)):
            return cls(float(value), float(value))
        initial, final = value
        return cls(float(initial), float(final))


def harmonic(initial: float, final: float, t: int, t_max: int) -> float:
    """Brause's learning rate (3.3): γ(t) = γ_i / (1 + t/τ) with τ = t_max / (γ_i/γ_f − 1), so
    γ(0) = γ_i and γ(t_max) = γ_f, and then on towards 0 without a floor (lim γ = 0, Σγ = ∞,
    Σγ² < ∞, the three conditions of (3.3)). γ_i = γ_f gives a constant rate.

    Args:
        initial, final: γ_i ≥ γ_f > 0. t: trials learned so far. t_max: trials of the run.
    """
    if not initial >= final > 0.0:
        raise ValueError(f"harmonic rate needs initial >= final > 0, got {initial}, {final}")
    if initial == final:
        return initial
    return initial / (1.0 + t * (initial / final - 1.0) / t_max)


@dataclass(frozen=True)
class Continual:
    """Continual learning: the schedules run back when the sensed error rises.

    The map keeps two running means of log e, e = |u − v0| the error it senses after the coarse
    move of a training trial (input units; the log makes the means robust to a rare large
    error): a fast one, weight ``fast`` per trial, and a slow reference, weight ``slow``. (The
    error after the fine move is no alarm: a camera shift moves both images by about the same
    amount, which the fine move corrects through an unchanged Jacobian.) Once
    the schedules have reached their floors (t ≥ t_max), a fast mean above ``trigger`` times the
    reference starts a re-adaptation: the schedules jump back to the fraction ``rewind`` of
    their course and run to their floors again in ``readapt`` trials. The reference holds still
    meanwhile and afterwards restarts from the fast mean (a lasting change of the error level,
    e.g. targets the changed arm cannot reach, then does not trigger again). With nothing
    changed the fast mean stays near the reference and the map learns as with the standard
    schedule.

    Args:
        fast, slow: weights of the newest trial in the two running means, 0 < slow < fast ≤ 1.
        trigger: error ratio that starts a re-adaptation, > 1.
        rewind: fraction of the schedules' course to jump back to, in [0, 1).
        readapt: trials to run from ``rewind`` back to the floors, ≥ 1.
    """

    fast: float = 0.02
    slow: float = 0.001
    trigger: float = 1.5
    # rewind and readapt: docs/decisions.md, "The map".
    rewind: float = 0.25
    readapt: int = 3000

    def __post_init__(self) -> None:
        for name in ("fast", "slow", "trigger", "rewind"):
            option_number("Continual", name, getattr(self, name), float)
        option_number("Continual", "readapt", self.readapt, int)
        if not (0 < self.slow < self.fast <= 1 and self.trigger > 1 and 0 <= self.rewind < 1):
            raise ValueError(
                "Continual needs 0 < slow < fast <= 1, trigger > 1 and 0 <= rewind < 1; got "
                f"{asdict(self)}"
            )
        if self.readapt < 1 or self.trigger > 1e9 or self.readapt > 2**53:
            raise ValueError(
                f"Continual needs readapt in [1, 2**53] trials and trigger <= 1e9, got "
                f"{self.readapt}, {self.trigger}"
            )


class ErrorMonitor:
    """The state of :class:`Continual` in one map: the two running means and the trial at which
    the current re-adaptation started (-1: none)."""

    def __init__(self, params: Continual, state: dict[str, float] | None = None) -> None:
        self.params = params
        state = state or {}
        self.fast = float(state.get("fast", math.nan))
        self.reference = float(state.get("reference", math.nan))
        self.start = int(state.get("start", -1))
        self.readaptations = int(state.get("readaptations", 0))

    def state(self) -> dict[str, float]:
        return {
            "fast": self.fast,
            "reference": self.reference,
            "start": self.start,
            "readaptations": self.readaptations,
        }

    def observe(self, t: int, t_max: int, error: float) -> bool:
        """Take the sensed error of trial ``t`` (input units); True if a re-adaptation starts."""
        p, x = self.params, math.log(max(error, 1e-12))
        if math.isnan(self.fast):
            self.fast = self.reference = x
            return False
        self.fast += p.fast * (x - self.fast)
        if self.start >= 0:
            if t - self.start < p.readapt:
                return False
            self.start, self.reference = -1, self.fast  # done: accept the level reached
        self.reference += p.slow * (x - self.reference)
        if t >= t_max and self.fast - self.reference > math.log(p.trigger):
            self.start = t
            self.readaptations += 1
            return True
        return False

    def fraction(self, t: int, t_max: int) -> float:
        """Where on their course (0 start, 1 floors) the schedules are at trial ``t``."""
        if self.start < 0:
            return min(t, t_max) / t_max
        p = self.params
        return p.rewind + (1.0 - p.rewind) * min(1.0, (t - self.start) / p.readapt)
