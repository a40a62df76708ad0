"""The human-facing frame of a reach env: both camera views and an overview, side by side.

Sensing happens in small images (320×240 by default), but people watch frames on large screens:
the panels may be drawn larger than the sensing images (pixels are scaled onto them), and every
overlay (target crosshair, detected marker, the trail of earlier detections, labels) is sized in
proportion to the panel, so that it stays legible when the frame is shown at full-HD size. A
marker detected on its target is drawn as one symbol, a green ring round a red dot, instead of a
circle over a crosshair (whose crossing lines read as a glitch); and a target sphere that the
arm's marker (a sphere of the target's size) touches is drawn in these frames as a larger
see-through shell, so that the marker inside it shows whole in red glass instead of as the
speckle of two intersecting spheres (sensing renders are not changed). Where
the arm is small in the camera images (the RIACS cameras see a large part of the unit cube), an
inset magnifies the neighbourhood of the target.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from envs.robots import PUMA_GRASP
from envs.sensing.drawn_spheres import spheres_drawn
from envs.sensing.rendering import VISIBLE_GROUPS
from envs.sensing.viewports import View, ViewportRenderer

PANELS = ("cam_left", "cam_right", "overview")
CROSSHAIR = (255, 40, 40)  # RGB: target, as sensed at reset
DETECTION = (40, 255, 40)  # RGB: effector marker, as detected after the last move
TRAIL = (255, 230, 0)  # RGB: the marker's earlier detections in this trial
WHITE, BLACK = (255, 255, 255), (0, 0, 0)
FONT = cv2.FONT_HERSHEY_SIMPLEX
#: Overlay sizes as fractions of the panel height.
CROSSHAIR_FRACTION = 0.06  # half-length of a crosshair arm
GAP_FRACTION = 0.025  # free centre of the crosshair, so that the target shows
CIRCLE_FRACTION = 0.03  # radius of the detection circle
#: A detection this close to its target (panel pixels, as a fraction of the height) is drawn as
#: the target reached: the crosshair's free centre, inside which circle and crosshair would cross.
REACHED_FRACTION = 0.025
RING_FRACTION = 0.045  # radius of the reached target's ring
LINE_FRACTION = 1 / 240  # line thickness
TEXT_FRACTION = 1 / 480  # OpenCV font scale per pixel of panel height
#: Render flags turned off: shadows and reflections make a frame several times slower to draw
#: in software GL (docs/decisions.md); the skybox and textures (the floor's checker) stay.
FRAME_OFF_FLAGS = ("mjRND_SHADOW", "mjRND_REFLECTION")
#: Grid spacing (m) the floor is drawn with (see ViewportRenderer's plane_grid).
PLANE_GRID = 0.5
#: The target's spheres (the reach task's, the grasp object's markers): one that an arm's marker
#: sphere (:data:`MARKERS`) touches is drawn as a larger see-through shell in the frames for
#: people, so that the marker inside it shows through (:mod:`envs.sensing.drawn_spheres`).
SEE_THROUGH = ("target", *PUMA_GRASP.target)
MARKERS = ("marker_wrist", "marker_tcp", *PUMA_GRASP.effector)  # the arms' marker spheres
#: The zoom inset: magnification, and the side of the magnified square (fraction of the height).
ZOOM, ZOOM_FRACTION = 3, 0.42


class CompositeView:
    """Left view | right view | overview, each (height, width), with sensing drawn on the views.

    The three views are viewports of one off-screen buffer, drawn without shadows, reflections
    or multisampling, the floor with a coarse lighting grid, and read back at once, colours
    only: a frame for people at a video's pace on software GL. The renderer starts at the
    first frame.

    Args:
        model: the scene's MjModel.
        height, width: size of each panel in pixels.
        sensing_size: (width, height) of the sensing images whose pixel coordinates
            :meth:`render` receives; default: the panel size.
        zoom: draw an inset magnifying the target's neighbourhood in each camera view.
        text_scale: OpenCV font scale of the panels' labels (default: in proportion to the
            height, :data:`TEXT_FRACTION`); larger for a frame shown small, as in the docs' GIFs.
    """

    def __init__(
        self,
        model,
        height: int,
        width: int,
        sensing_size: tuple[int, int] | None = None,
        zoom: bool = False,
        text_scale: float | None = None,
    ) -> None:
        self.height, self.width, self.zoom = height, width, zoom
        sensing_width = width if sensing_size is None else sensing_size[0]
        self._scale = width / sensing_width  # panel pixels per sensing pixel
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
        self._line = max(1, round(height * LINE_FRACTION))
        names = [model.geom(i).name for i in range(model.ngeom)]
        self._see_through = np.array([names.index(n) for n in SEE_THROUGH if n in names], int)
        self._markers = np.array([names.index(n) for n in MARKERS if n in names], int)
        self._model = model
        self._text = height * TEXT_FRACTION if text_scale is None else text_scale

    def to_panel(self, px: np.ndarray) -> np.ndarray:
        """Sensing-image pixel coordinates (any shape) -> panel pixel coordinates (centres of
        pixels map onto centres)."""
        return (np.asarray(px, dtype=float) + 0.5) * self._scale - 0.5

    def render(
        self,
        data,
        target_px: np.ndarray,
        effector_px: np.ndarray,
        trail: Sequence[np.ndarray] = (),
    ) -> np.ndarray:
        """(height, 3·width, 3) uint8 RGB: the :meth:`panels` side by side."""
        return np.concatenate(self.panels(data, target_px, effector_px, trail), axis=1)

    def panels(
        self,
        data,
        target_px: np.ndarray,
        effector_px: np.ndarray,
        trail: Sequence[np.ndarray] = (),
    ) -> list[np.ndarray]:
        """The left view, the right view and the overview, (height, width, 3) uint8 RGB each.

        Args:
            data: the MjData to draw.
            target_px, effector_px: (4M,) sensing pixels (left u, v, right u, v) of M markers
                each (the reach task's one, the grasp task's three); NaN entries (not seen) are
                not drawn.
            trail: earlier detections (4,) each of the first marker, joined by a line in their
                order.
        """
        with spheres_drawn(self._model, data, self._see_through, self._markers):
            images = self._renderer.render(data, self._views, VISIBLE_GROUPS, depth=False)
        panels = []
        for k, name in enumerate(PANELS[:2]):
            view = np.ascontiguousarray(images[k][0])
            self._label(view, name)  # first: the sensing drawn over it stays whole
            pick = slice(2 * k, 2 * k + 2)
            points = [self.to_panel(p[pick]) for p in trail if np.all(np.isfinite(p[pick]))]
            self._trail(view, points)
            for first in range(0, len(target_px), 4):  # each marker: 4 pixels
                marker = slice(first + 2 * k, first + 2 * k + 2)
                target, effector = (
                    self.to_panel(target_px[marker]),
                    self.to_panel(effector_px[marker]),
                )
                draw_marker(view, target, effector, self.height)
            target = self.to_panel(target_px[pick])
            if self.zoom and np.all(np.isfinite(target)):
                draw_inset(view, target, self._text)
            panels.append(view)
        overview = np.ascontiguousarray(images[2][0])
        self._label(overview, "overview")
        panels.append(overview)
        return panels

    def _trail(self, image: np.ndarray, points: list[np.ndarray]) -> None:
        if len(points) > 1:
            line = np.array([_int(p) for p in points], dtype=np.int32)
            cv2.polylines(image, [line], False, TRAIL, self._line, cv2.LINE_AA)
        for p in points:
            cv2.circle(image, _int(p), self._line + 1, TRAIL, -1, cv2.LINE_AA)

    def label_box(self, text: str) -> tuple[int, int, int, int]:
        """(left, top, right, bottom) px of a panel's label ``text``, outline included: in the
        bottom-right corner, the one the arm crosses least in every scene's camera views (of
        150 random moves: RIACS 0 %, PUMA 0 %, grasp 0.3 %; the bottom left, where labels were,
        RIACS 50 %), clear of the target's inset (top right)."""
        thickness = max(1, round(self._text * 2)) + 2  # the black outline's
        (width, height), baseline = cv2.getTextSize(text, FONT, self._text, thickness)
        margin = round(self.height * 0.02)
        right, bottom = self.width - margin, self.height - margin
        return right - width, bottom - height - baseline, right, bottom

    def _label(self, image: np.ndarray, text: str) -> None:
        left, top, _, _ = self.label_box(text)
        thickness = max(1, round(self._text * 2))
        (_, height), _ = cv2.getTextSize(text, FONT, self._text, thickness + 2)
        origin = (left, top + height)  # putText's origin is the text's bottom left
        cv2.putText(image, text, origin, FONT, self._text, BLACK, thickness + 2, cv2.LINE_AA)
        cv2.putText(image, text, origin, FONT, self._text, WHITE, thickness, cv2.LINE_AA)

    def close(self) -> None:
        self._renderer.close()


def draw_marker(image: np.ndarray, target: np.ndarray, effector: np.ndarray, height: int) -> None:
    """One marker's target (a crosshair) and detection (a circle), (u, v) panel pixels each, on
    a panel ``height`` pixels high; NaN: not drawn. A detection on the target (:func:`reached`)
    is drawn as one symbol, a green ring round a red dot."""
    line = max(1, round(height * LINE_FRACTION))
    seen, sensed = bool(np.all(np.isfinite(target))), bool(np.all(np.isfinite(effector)))
    if seen and sensed and reached(target, effector, height):
        centre, ring = _int(target), round(height * RING_FRACTION)
        cv2.circle(image, centre, ring, BLACK, line + 2, cv2.LINE_AA)
        cv2.circle(image, centre, ring, DETECTION, line, cv2.LINE_AA)
        cv2.circle(image, centre, line + 2, BLACK, -1, cv2.LINE_AA)
        cv2.circle(image, centre, line + 1, CROSSHAIR, -1, cv2.LINE_AA)
        return
    if seen:
        _crosshair(image, target, height, line)
    if sensed:
        radius = round(height * CIRCLE_FRACTION)
        cv2.circle(image, _int(effector), radius, BLACK, line + 2, cv2.LINE_AA)
        cv2.circle(image, _int(effector), radius, DETECTION, line, cv2.LINE_AA)


def _crosshair(image: np.ndarray, uv: np.ndarray, height: int, line: int) -> None:
    u, v = _int(uv)
    size, gap = round(height * CROSSHAIR_FRACTION), round(height * GAP_FRACTION)
    for du, dv in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        start = (u + du * gap, v + dv * gap)
        end = (u + du * size, v + dv * size)
        cv2.line(image, start, end, BLACK, line + 2, cv2.LINE_AA)
        cv2.line(image, start, end, CROSSHAIR, line, cv2.LINE_AA)


def reached(target: np.ndarray, effector: np.ndarray, height: int) -> bool:
    """Whether a detection (u, v panel pixels) lies inside its target's crosshair centre, on a
    panel ``height`` pixels high: drawn as the target reached."""
    return float(np.hypot(*(np.asarray(effector) - target))) <= height * REACHED_FRACTION


def draw_inset(image: np.ndarray, centre: np.ndarray, text_scale: float) -> None:
    """Magnify the square about ``centre`` (u, v pixels) ZOOM times into the top-right corner
    of ``image`` (in place), framed in white, and frame the magnified square in the image."""
    height, width = image.shape[:2]
    side = round(height * ZOOM_FRACTION)  # of the inset
    half = side // (2 * ZOOM)  # of the source square
    u = int(np.clip(round(float(centre[0])), half, width - half))
    v = int(np.clip(round(float(centre[1])), half, height - half))
    source = image[v - half : v + half, u - half : u + half].copy()
    inset = cv2.resize(source, (2 * half * ZOOM, 2 * half * ZOOM), interpolation=cv2.INTER_LINEAR)
    cv2.rectangle(image, (u - half, v - half), (u + half, v + half), WHITE, 1, cv2.LINE_AA)
    h, w = inset.shape[:2]
    image[: h + 4, width - w - 4 :] = WHITE
    image[2 : h + 2, width - w - 2 : width - 2] = inset
    origin = (width - w + 4, h - 6)
    cv2.putText(image, f"{ZOOM}x", origin, FONT, text_scale, WHITE, 1, cv2.LINE_AA)


def _int(uv: np.ndarray) -> tuple[int, int]:
    return round(float(uv[0])), round(float(uv[1]))
