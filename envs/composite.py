"""The human-facing frame of a reach env: both camera views and an overview, side by side."""

from __future__ import annotations

import cv2
import numpy as np

from envs.sensing.viewports import VISIBLE_GROUPS, View, ViewportRenderer

PANELS = ("cam_left", "cam_right", "overview")
#: Render flags turned off: shadows and reflections cost most on software GL; the skybox and
#: textures (the floor's checker) stay.
FRAME_OFF_FLAGS = ("mjRND_SHADOW", "mjRND_REFLECTION")
#: Grid spacing (m) the floor is drawn with (see ViewportRenderer's plane_grid).
PLANE_GRID = 0.5
CROSSHAIR = (255, 60, 60)  # target, as sensed at reset
DETECTION = (60, 255, 60)  # effector marker, as detected after the last move


class CompositeView:
    """Left view | right view | overview, each (height, width), with sensing drawn on the views.

    The three views are viewports of one off-screen buffer, drawn without shadows, reflections
    or multisampling, the floor with a coarse lighting grid, and read back at once, colours
    only: a frame for people at a video's pace on software GL. The renderer starts at the
    first frame.
    """

    def __init__(self, model, height: int, width: int) -> None:
        self.height, self.width = height, width
        self._renderer = ViewportRenderer(
            model,
            height,
            len(PANELS) * width,
            FRAME_OFF_FLAGS,
            textures=True,
            own_headlight=True,
            plane_grid=PLANE_GRID,
            facets=None,  # the model's
        )
        self._views = [View.whole(name, height, width) for name in PANELS]

    def render(self, data, target_px: np.ndarray, effector_px: np.ndarray) -> np.ndarray:
        """(height, 3·width, 3) uint8; NaN effector pixels (not visible) are not drawn."""
        images = self._renderer.render(data, self._views, VISIBLE_GROUPS, depth=False)
        panels = []
        for k, name in enumerate(PANELS[:2]):
            view = np.ascontiguousarray(images[k][0])
            _crosshair(view, target_px[2 * k : 2 * k + 2])
            if np.all(np.isfinite(effector_px[2 * k : 2 * k + 2])):
                centre = tuple(round(float(c)) for c in effector_px[2 * k : 2 * k + 2])
                cv2.circle(view, centre, 7, DETECTION, 1, cv2.LINE_AA)
            cv2.putText(
                view,
                name,
                (6, self.height - 8),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.45,
                (255, 255, 255),
                1,
                cv2.LINE_AA,
            )
            panels.append(view)
        panels.append(images[2][0])
        return np.concatenate(panels, axis=1)

    def close(self) -> None:
        self._renderer.close()


def _crosshair(image: np.ndarray, uv: np.ndarray, size: int = 9) -> None:
    u, v = (round(float(c)) for c in uv)
    cv2.line(image, (u - size, v), (u + size, v), CROSSHAIR, 1, cv2.LINE_AA)
    cv2.line(image, (u, v - size), (u, v + size), CROSSHAIR, 1, cv2.LINE_AA)
