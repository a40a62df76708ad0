"""Checks the learners share: numbers that must be finite, and inputs that must lie in (a wide
margin around) the box the learner was built for. A finite but absurd input (say u = 1e200
pixels) would otherwise pass every NaN check and wreck every neuron it reaches."""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

#: Inputs more than this many box sizes outside a learner's input box are refused (e.g. pixels
#: beyond 10 image widths: no camera senses those).
INPUT_MARGIN = 10.0
#: No bound of a box or joint range lies farther from 0 than this, in the learner's units
#: (pixels, metres, radians): no image, workspace or joint is that large.
BOUND_LIMIT = 1e9


def check_finite(**values: object) -> None:
    """ValueError naming every argument that is not finite (NaN or ±inf anywhere in it)."""
    bad = [k for k, v in values.items() if not np.all(np.isfinite(np.asarray(v, dtype=float)))]
    if bad:
        raise ValueError(f"{', '.join(bad)} must be finite, got " + ", ".join(
            f"{k}={values[k]!r}" for k in bad
        ))  # fmt: skip


class InputBox:
    """[low − m·(high − low), high + m·(high − low)] per component, m = ``INPUT_MARGIN``."""

    def __init__(self, low: np.ndarray, high: np.ndarray, what: str) -> None:
        low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        self.low, self.high, self.what = low, high, what
        self.centre = (low + high) / 2
        self.inv_half = 1.0 / ((high - low) * (INPUT_MARGIN + 0.5))

    def inside(self, a: np.ndarray) -> bool:
        """Whether every component of ``a`` (..., n) lies in the box (False for NaN)."""
        return bool((np.abs(a - self.centre) * self.inv_half).max(initial=0.0) <= 1.0)

    def check(self, name: str, a: np.ndarray) -> None:
        """ValueError naming ``a`` (or its first bad row) if it is outside the box."""
        if self.inside(a):
            return
        a = np.asarray(a, dtype=float)
        if a.ndim > 1:
            rows = a.reshape(-1, a.shape[-1])
            row = next(i for i, r in enumerate(rows) if not self.inside(r))
            name, a = f"row {row} of {name}", rows[row]
        raise ValueError(
            f"{name} = {a.tolist()} lies more than {INPUT_MARGIN:g} box sizes outside the "
            f"{self.what} [{self.low.tolist()}, {self.high.tolist()}]; pass values in the units "
            "the learner was built for"
        )


def positive_int(name: str, value: object) -> int:
    """``value`` as an int >= 1 (an integral float is accepted), else ValueError."""
    number = float(value)  # type: ignore[arg-type]
    if not (math.isfinite(number) and number >= 1 and number == int(number)):
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    return int(number)


def option_number(owner: str, name: str, value: Any, kind: type) -> Any:
    """``value`` as ``kind`` (int or float), else ValueError naming ``owner.name``."""
    try:
        finite = not isinstance(value, bool) and isinstance(value, numbers.Real)
        finite = finite and math.isfinite(value)
    except OverflowError:  # an int beyond any float
        finite = False
    if not finite:
        raise ValueError(f"{owner}.{name} must be a finite {kind.__name__}, got {value!r:.40}")
    if kind is int and value != int(value):
        raise ValueError(f"{owner}.{name} must be an integer, got {value!r:.40}")
    return kind(value)


def _values(a: np.ndarray) -> str:
    """``a`` for an error message: its values if there are a few, else its shape."""
    return str(a.tolist()) if a.size <= 12 else f"of shape {a.shape}"


def bounds(
    names: tuple[str, str], low: Any, high: Any, size: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) as float arrays (n,), else ValueError naming ``names``: finite, of one shape
    (``size`` entries if given, at least one), low < high, within ±``BOUND_LIMIT``."""
    lo, hi = np.array(low, dtype=float).ravel(), np.array(high, dtype=float).ravel()
    pair = f"{names[0]}/{names[1]}"
    n = lo.size if size is None else size
    if lo.shape != hi.shape or lo.shape != (n,) or n < 1:
        raise ValueError(f"{pair} must both have shape ({n},), got {lo.shape} and {hi.shape}")
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise ValueError(f"{pair} must be finite, got {_values(lo)} and {_values(hi)}")
    if not np.all(lo < hi):
        raise ValueError(f"{pair} need lower < upper, got {_values(lo)} and {_values(hi)}")
    if max(np.abs(lo).max(), np.abs(hi).max()) > BOUND_LIMIT:
        raise ValueError(
            f"{pair} reach {max(np.abs(lo).max(), np.abs(hi).max()):.3g}, beyond "
            f"±{BOUND_LIMIT:g} (pixels, metres or radians); pass bounds in the learner's units"
        )
    return lo, hi


def joint_ranges(joint_lower: Any, joint_upper: Any) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) as float arrays (J,), else ValueError: :func:`bounds`, one entry per
    joint each."""
    return bounds(("joint_lower", "joint_upper"), joint_lower, joint_upper)
