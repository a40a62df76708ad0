"""Marker spheres drawn for people and agents other than as the sensing cameras see them.

An arm's marker sphere on its target (a sphere of the same size at the same place) renders as a
speckle of the two fighting for the same pixels. Views that nobody senses from draw a target
sphere that a marker touches as a larger see-through shell, so that the marker inside shows whole
through it, and may draw both larger than they are (an agent's small image). The model is changed
only while such a view is drawn: sensing renders see the spheres as they are.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import mujoco

#: A target sphere that a marker touches is drawn this much larger and with this opacity.
TARGET_SCALE, TARGET_ALPHA = 1.3, 0.35


def touched(
    data: mujoco.MjData,
    targets: np.ndarray,
    target_radii: np.ndarray,
    markers: np.ndarray,
    marker_radii: np.ndarray,
) -> np.ndarray:
    """Those of the target sphere geoms ``targets`` (T,) that a marker sphere ``markers`` (M,)
    intersects, for spheres of the given radii (T,), (M,) m."""
    if not len(targets) or not len(markers):
        return targets[:0]
    gap = np.linalg.norm(
        data.geom_xpos[targets, None] - data.geom_xpos[None, markers], axis=-1
    )  # (T, M) m between centres
    touching = gap < target_radii[:, None] + marker_radii[None]
    return targets[touching.any(axis=1)]


@contextmanager
def spheres_drawn(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    targets: np.ndarray,
    markers: np.ndarray,
    radius: float | None = None,
) -> Iterator[None]:
    """Inside the block, the model draws the target and marker sphere geoms (ids (T,), (M,))
    with a radius of at least ``radius`` m (None: their own), and each target that a marker so
    drawn touches as a see-through shell TARGET_SCALE larger at TARGET_ALPHA; after it, the
    model is as it was."""
    spheres = np.concatenate([targets, markers]).astype(int)
    size, rgba = model.geom_size, model.geom_rgba
    saved_size, saved_alpha = size[spheres].copy(), rgba[targets, 3].copy()
    try:
        if radius is not None:
            size[spheres, 0] = np.maximum(size[spheres, 0], radius)
        shells = touched(data, targets, size[targets, 0], markers, size[markers, 0])
        size[shells] *= TARGET_SCALE
        rgba[shells, 3] = TARGET_ALPHA
        yield
    finally:
        size[spheres], rgba[targets, 3] = saved_size, saved_alpha
