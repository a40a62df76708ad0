"""numba, when it is installed (extra ``fast``): the decorator of the compiled kernels."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

numba: Any
try:
    numba = importlib.import_module("numba")
except ImportError:  # the numpy path is used
    numba = None


def available() -> bool:
    return numba is not None


def jit(function: F) -> F:
    """Compiled with numba (cached on disk), or the plain Python function without numba."""
    if numba is None:
        return function
    compiled: F = numba.njit(cache=True, nogil=True)(function)
    return compiled
