"""Checks of env arguments, run before an env changes any state or draws a random number; each
error names the argument, what it got and what it takes."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from numbers import Integral, Real
from typing import Any

import numpy as np


def positive_int(name: str, value: Any) -> int:
    """An integer >= 1 (not a float, not a bool), else ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, Integral) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


def positive_number(name: str, value: Any) -> float:
    """A finite real > 0, else ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    if value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def seed(name: str, value: Any) -> int:
    """A seed for ``numpy.random.default_rng``: an integer >= 0 (not a bool), else ValueError."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Integral) or value < 0:
        raise ValueError(f"{name} must be an integer >= 0 or None, got {value!r}")
    return int(value)


def reset_options(
    options: Any, allowed: Mapping[str, Callable[[Any], bool]], wanted: str
) -> dict[str, Any]:
    """``options`` of ``reset`` as a dict whose keys are in ``allowed`` and whose values pass
    ``allowed[key]``; ``wanted`` describes the valid options for the message."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(f"reset options must be a dict ({wanted}), got {options!r}")
    for key, value in options.items():
        if key not in allowed:
            raise ValueError(f"unknown reset option {key!r}; valid: {wanted}")
        if not allowed[key](value):
            raise ValueError(f"reset option {key!r} got {value!r}; valid: {wanted}")
    return dict(options)


def real_numbers(
    name: str, value: Any, takes: str, error: type[ValueError] = ValueError
) -> np.ndarray:
    """``value`` as a float array if it holds only real numbers, else ``error`` naming ``name``.

    Floats of any precision and integers are numbers (a float64 ``gymnasium.spaces.Box``
    contains integer arrays, and an integer converts exactly); bools, strings (numpy would parse
    ``'0.1'``), complex numbers (numpy would drop the imaginary part with only a warning) and
    other objects are refused: they are mistakes, not commands.

    Args:
        takes: what ``name`` takes, for the message (``"real numbers (rad)"``).
    """
    if isinstance(value, np.ndarray) and value.dtype.kind in "fiu":
        return np.asarray(value, dtype=float)
    if isinstance(value, np.ndarray) and value.dtype.kind != "O":
        wrong = WRONG_KINDS.get(value.dtype.kind, f"{value.dtype} values")
        raise error(f"{name} must be {takes}, got {wrong} {_shown(value)}")
    try:
        items = np.asarray(value, dtype=object)
    except (ValueError, TypeError) as exc:
        raise error(f"{name} must be {takes}, got {value!r} ({exc})") from None
    for item in items.flat:
        if isinstance(item, (bool, np.bool_)) or not isinstance(item, Real):
            where = "" if items.ndim == 0 else f" in {_shown(value)}"
            raise error(f"{name} must be {takes}, got {item!r}{where}")
    try:
        return np.asarray(value, dtype=float)
    except (ValueError, TypeError, OverflowError) as exc:
        raise error(f"{name} must be {takes}, got {_shown(value)} ({exc})") from None


#: What a numpy array of a dtype kind holds, for messages about arrays that are not numbers.
WRONG_KINDS = {"b": "bools", "c": "complex numbers", "U": "strings", "S": "bytes"}


def _shown(value: Any) -> str:
    """``value`` on one line (numpy wraps a long array's repr)."""
    if isinstance(value, np.ndarray):
        return f"array({value.tolist()!r}, dtype={value.dtype})"
    return repr(value)
