"""Decaying training parameters of the Kohonen map (learning rates, widths).

Ritter, Martinetz & Schulten (1989, 1990) let every parameter x fall geometrically from x_i to
x_f over the t_max training steps:

    x(t) = x_i (x_f / x_i)^(t / t_max)

Beyond t_max the value stays at x_f (the rule would otherwise keep shrinking it): a floor, unlike
Brause's (3.3), whose γ → 0; :func:`harmonic` is a rate that satisfies (3.3).
"""

from __future__ import annotations

from dataclasses import dataclass


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
        if self.initial == 0.0:
            return 0.0
        frac = min(t, t_max) / t_max
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
