"""The human-facing frame of a reach env: both camera views and an overview, side by side."""

from __future__ import annotations

import cv2
import numpy as np

from envs.sensing.rendering import (
    GROUP_MARKER,
    GROUP_ROBOT,
    GROUP_SCENE,
    GROUP_TARGET,
    CameraRenderer,
)

VISIBLE_GROUPS = (GROUP_SCENE, GROUP_TARGET, GROUP_ROBOT, GROUP_MARKER)
CROSSHAIR = (255, 60, 60)  # target, as sensed at reset
DETECTION = (60, 255, 60)  # effector marker, as detected after the last move


class CompositeView:
    """Left view | right view | overview, each (height, width), with sensing drawn on the views."""

    def __init__(self, model, height: int, width: int) -> None:
        self.height, self.width = height, width
        self._cameras = CameraRenderer(model, height, width, fast=False)
        self._overview = CameraRenderer(model, height, width, fast=False)

    def render(self, data, target_px: np.ndarray, effector_px: np.ndarray) -> np.ndarray:
        """(height, 3·width, 3) uint8; NaN effector pixels (not visible) are not drawn."""
        panels = []
        for k, name in enumerate(("cam_left", "cam_right")):
            view = np.ascontiguousarray(self._cameras.render(data, name, VISIBLE_GROUPS))
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
        panels.append(self._overview.render(data, "overview", VISIBLE_GROUPS))
        return np.concatenate(panels, axis=1)

    def close(self) -> None:
        self._cameras.close()
        self._overview.close()


def _crosshair(image: np.ndarray, uv: np.ndarray, size: int = 9) -> None:
    u, v = (round(float(c)) for c in uv)
    cv2.line(image, (u - size, v), (u + size, v), CROSSHAIR, 1, cv2.LINE_AA)
    cv2.line(image, (u, v - size), (u, v + size), CROSSHAIR, 1, cv2.LINE_AA)
