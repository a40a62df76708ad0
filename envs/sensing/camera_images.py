"""The images an agent sees (``obs_mode="pixels"`` of the reach envs): whole camera views,
unannotated, at a size of the agent's choosing."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from envs.sensing.drawn_spheres import spheres_drawn
from envs.sensing.rendering import VISIBLE_GROUPS
from envs.sensing.viewports import View, ViewportRenderer

if TYPE_CHECKING:
    import mujoco  # imported at run time only where used: envs picks the GL back-end first

#: Grid spacing (m) the floor is drawn with (see ViewportRenderer's plane_grid): half the cost
#: of a small image.
PLANE_GRID = 0.5
#: Slices and stacks of spheres, capsules and cylinders: facets of 22.5°, whose outline stays
#: within 2 % of a radius of a circle (a fraction of a pixel in an agent's small image); the
#: triangles, not the pixels, are most of the cost of an 84 × 84 image on software GL.
FACETS = (16, 8)


class CameraImages:
    """RGB images of camera views, each (height, width, 3) uint8, drawn as viewports of one
    off-screen buffer and read back at once (colours only).

    The scene is drawn as the sensing cameras draw it (no shadows, reflections, skybox,
    textures or multisampling; floor, target, robot and marker) but with coarser meshes
    (FACETS) and floor grid (PLANE_GRID), each view lit by its own headlight, without anything
    the env sensed drawn on it. The target and marker spheres are drawn at least ``radius``
    m large, a target that a marker touches as a see-through shell
    (:func:`envs.sensing.drawn_spheres.spheres_drawn`). The renderer starts at the first image
    (GL resources are not pickled).

    Args:
        model: the MuJoCo model; views: whole views, one per image (:meth:`View.posed`, or
            :meth:`View.whole` of a model camera); height, width: pixels per image.
        targets, markers: the target's and the marker's sphere geom ids; radius: m, or None
            (as they are).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        views: Sequence[View],
        height: int,
        width: int,
        targets: np.ndarray,
        markers: np.ndarray,
        radius: float | None = None,
    ) -> None:
        self.views, self.height, self.width = list(views), height, width
        self.targets, self.markers, self.radius = targets, markers, radius
        self._model = model
        self._renderer = ViewportRenderer(
            model,
            height,
            len(self.views) * width,
            own_headlight=True,
            plane_grid=PLANE_GRID,
            facets=FACETS,
        )

    def render(self, data: mujoco.MjData) -> list[np.ndarray]:
        """One image (height, width, 3) uint8 per view, rows top first, of the positions in
        ``data``."""
        with spheres_drawn(self._model, data, self.targets, self.markers, self.radius):
            images = self._renderer.render(data, self.views, VISIBLE_GROUPS, depth=False)
        return [np.ascontiguousarray(rgb) for rgb, _ in images]

    def close(self) -> None:
        """Free the GL resources now (a later render makes new ones)."""
        self._renderer.close()
