"""numba, when it is installed (extra ``fast``): the decorator of the compiled kernels."""

from __future__ import annotations

try:
    import numba
except ImportError:  # the numpy path is used
    numba = None


def available() -> bool:
    return numba is not None


def jit(function):
    """Compiled with numba (cached on disk), or the plain Python function without numba."""
    return numba.njit(cache=True, nogil=True)(function) if numba is not None else function
