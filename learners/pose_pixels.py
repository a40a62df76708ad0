"""The pose task's camera input: three markers' pixels, checked with one-line errors."""

from __future__ import annotations

import numpy as np

#: Markers of the pose task, each seen as (u_left, v_left, u_right, v_right).
MARKERS = 3
#: Pixels of a pose: three markers × four pixel coordinates.
PIXELS = 4 * MARKERS


def check_pose_pixels(name: str, x: np.ndarray) -> np.ndarray:
    """``x`` as (12,) finite floats, else a one-line ValueError saying what is wrong."""
    a = np.asarray(x, dtype=float)
    if a.shape != (PIXELS,):
        raise ValueError(
            f"{name} must be the {PIXELS} pixels of {MARKERS} markers, shape ({PIXELS},); "
            f"got shape {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        bad = np.flatnonzero(~np.isfinite(a)).tolist()
        raise ValueError(
            f"{name} holds NaN or inf at entries {bad}; pass the pixels of markers seen by both "
            "cameras"
        )
    return a
