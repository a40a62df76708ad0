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


def real_array(name: str, value: Any) -> np.ndarray:
    """``value`` as a float array, refusing complex numbers (numpy would drop the imaginary
    part with only a warning)."""
    if np.iscomplexobj(value):
        raise ValueError(f"{name} must be real numbers (rad), got complex {value!r}")
    return np.asarray(value, dtype=float)
