"""The sensing cameras' images as an agent sees them: both whole views, unannotated, at a size
of the agent's choosing (``obs_mode="pixels"`` of the reach envs)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

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
    """RGB images of named cameras, each (height, width, 3) uint8, drawn as viewports of one
    off-screen buffer and read back at once (colours only).

    Each camera's whole field of view, vertically, as the model defines it; a width-to-height
    ratio other than the camera's sees more or less of the sides. The scene is drawn as the
    sensing cameras draw it (no shadows, reflections, skybox, textures or multisampling; floor,
    target, robot and marker) but with coarser meshes (FACETS) and floor grid (PLANE_GRID),
    each camera lit by its own headlight, without anything the env sensed drawn on it. The
    renderer starts at the first image (GL resources are not pickled).

    Args:
        model: the MuJoCo model; cameras: camera names; height, width: pixels per image.
    """

    def __init__(
        self, model: mujoco.MjModel, cameras: Sequence[str], height: int, width: int
    ) -> None:
        self.cameras, self.height, self.width = tuple(cameras), height, width
        self._renderer = ViewportRenderer(
            model,
            height,
            len(self.cameras) * width,
            own_headlight=True,
            plane_grid=PLANE_GRID,
            facets=FACETS,
        )
        self._views = [View.whole(name, height, width) for name in self.cameras]

    def render(self, data: mujoco.MjData) -> list[np.ndarray]:
        """One image (height, width, 3) uint8 per camera, rows top first, of the positions in
        ``data``."""
        images = self._renderer.render(data, self._views, VISIBLE_GROUPS, depth=False)
        return [np.ascontiguousarray(rgb) for rgb, _ in images]

    def close(self) -> None:
        """Free the GL resources now (a later render makes new ones)."""
        self._renderer.close()
