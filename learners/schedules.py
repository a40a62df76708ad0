"""Exponentially decaying training parameters of the Kohonen map (learning rates, widths).

Ritter, Martinetz & Schulten (1989, 1990) let every parameter x fall geometrically from x_i to
x_f over the t_max training steps:

    x(t) = x_i (x_f / x_i)^(t / t_max)

Beyond t_max the value stays at x_f (the rule would otherwise keep shrinking it).
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
