"""Two fixed pinhole cameras of a scene: exact projection, triangulation and rendered sensing.

Pixel coordinates are array-index coordinates: the centre of pixel (row i, column j) is
(u, v) = (j, i), u to the right and v downwards. Normalised image coordinates have focal length 1,
x to the right and y up. A 4-vector of pixels is (u_left, v_left, u_right, v_right).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from envs.sensing import pinhole_kernels
from envs.sensing.marker_detection import (
    MarkerColour,
    find_blob,
    find_sphere,
    outline_edges,
    perspective_centre,
    pixel_moments,
)
from envs.sensing.marker_fit import CameraOutline, locate
from envs.sensing.render_memo import RenderMemo
from envs.sensing.rendering import GROUP_MARKER, GROUP_ROBOT, GROUP_SCENE, GROUP_TARGET
from envs.sensing.triangulation import camera_array, camera_floats, triangulate_elementwise
from envs.sensing.viewports import View, ViewportRenderer, Window

if TYPE_CHECKING:
    import mujoco  # imported at run time only where used: envs picks the GL back-end first

#: Grid spacing (m) the sensing cameras draw the floor with (ViewportRenderer's plane_grid).
#: The scenes' 0.05 m grid makes a 16 m floor of about 10^5 quads, half the cost of a whole
#: view on software GL; the grid sets only the floor's per-vertex lighting, which no sighting
#: reads (the markers are found by their own colours; the floor, far behind them, only ever
#: counts as "farther" beside an outline), so sightings are bit-identical (tests/test_stereo.py).
SENSING_PLANE_GRID = 0.5
#: An outline point's outside neighbour must be this many sphere radii farther than the sphere
#: there: a link that passes through the marker meets it at about the same depth.
OUTLINE_DEPTH_MARGIN = 0.25


@dataclass(frozen=True)
class PinholeCamera:
    """World pose and intrinsics of one camera, in pixels of a (height, width) image."""

    position: np.ndarray  # (3,) world
    rotation: np.ndarray  # (3, 3) columns = camera x (right), y (up), z (backwards) in world
    focal: np.ndarray  # (2,) pixels per unit of normalised coordinate, (f_u, f_v)
    center: np.ndarray  # (2,) pixel (u, v) of the optical axis

    @classmethod
    def from_model(
        cls, model: mujoco.MjModel, data: mujoco.MjData, name: str, height: int, width: int
    ) -> PinholeCamera:
        """Read a MuJoCo camera (``fovy`` or ``sensorsize``/``focal``/``principal``)."""
        cid = model.camera(name).id
        sensor = model.cam_sensorsize[cid]
        if sensor[1] > 0:  # physical sensor: intrinsic = (focal x, focal y, principal x, y)
            fx, fy, px, py = model.cam_intrinsic[cid]
            focal = np.array([fx * width / sensor[0], fy * height / sensor[1]])
            # MuJoCo shifts the image by -principal (x right, y down), measured in sensor units.
            center = np.array(
                [
                    width / 2 - 0.5 - px * width / sensor[0],
                    height / 2 - 0.5 - py * height / sensor[1],
                ]
            )
        else:
            f = 0.5 * height / np.tan(np.deg2rad(model.cam_fovy[cid]) / 2)
            focal = np.array([f, f])
            center = np.array([width / 2 - 0.5, height / 2 - 0.5])
        return cls(
            data.cam_xpos[cid].copy(), data.cam_xmat[cid].reshape(3, 3).copy(), focal, center
        )

    def to_normalized(self, uv: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) -> normalised (N, 2)."""
        return np.stack(
            [
                (uv[:, 0] - self.center[0]) / self.focal[0],
                (self.center[1] - uv[:, 1]) / self.focal[1],
            ],
            axis=-1,
        )

    def projection_matrix(self, normalized: bool = False) -> np.ndarray:
        """P (3, 4) with P [p; 1] = depth · (u, v, 1) (pixels, or normalised with x, y up)."""
        K = np.eye(3)
        if not normalized:
            (fu, fv), (cu, cv) = self.focal, self.center
            K = np.array([[fu, 0.0, cu], [0.0, -fv, cv], [0.0, 0.0, 1.0]])
        M = self.rotation.T * np.array([[1.0], [1.0], [-1.0]])  # rows x, y, -z: depth > 0 ahead
        return K @ np.hstack([M, -M @ self.position[:, None]])

    @cached_property
    def pixel_projection(self) -> np.ndarray:
        """P (3, 4) in pixels (:meth:`projection_matrix`), computed once."""
        return self.projection_matrix()

    def project(self, points: np.ndarray) -> np.ndarray:
        """World points (N, 3) -> pixels (N, 2)."""
        P = self.pixel_projection
        h = np.atleast_2d(np.asarray(points, dtype=float)) @ P[:, :3].T + P[:, 3]  # (N, 3)
        return h[:, :2] / h[:, 2:3]

    def sphere_semi_axes(self, centres: np.ndarray, radius: float) -> np.ndarray:
        """Semi-axes (N, 2) px (radial, across) of the image of a sphere of ``radius`` (m) at
        each centre (N, 3).

        The image is an ellipse: with α the half-angle the sphere subtends and φ the off-axis
        angle of its centre, semi-axes sin α cos α / (cos²φ - sin²α) (radial) and
        sin α / √(cos²φ - sin²α) in normalised coordinates.
        """
        local = (np.atleast_2d(np.asarray(centres, dtype=float)) - self.position) @ self.rotation
        distance = np.linalg.norm(local, axis=-1)  # (N,)
        sin_a = np.minimum(radius / distance, 1.0)
        cos_phi = -local[:, 2] / distance
        spread = np.maximum(cos_phi**2 - sin_a**2, 1e-12)
        major = sin_a * np.sqrt(1.0 - sin_a**2) / spread
        minor = sin_a / np.sqrt(spread)
        return np.stack([major, minor], axis=-1) * np.sqrt(self.focal[0] * self.focal[1])

    def sphere_area(self, centres: np.ndarray, radius: float) -> np.ndarray:
        """Area (N,) px² of the image of a sphere of ``radius`` (m) at each centre (N, 3)."""
        return np.pi * np.prod(self.sphere_semi_axes(centres, radius), axis=-1)


class CameraPair:
    """Two pinhole cameras as they are now: exact projection and triangulation, no rendering.

    A :class:`StereoRig` is a CameraPair that renders and follows its scene;
    ``CameraPair(rig.cameras)`` keeps a rig's cameras as they were (the nominal calibration that
    the exact baselines use, which goes stale when the scene changes).
    """

    def __init__(self, cameras: Sequence[PinholeCamera]) -> None:
        if len(cameras) != 2:
            raise ValueError(f"a stereo pair needs two cameras, got {len(cameras)}")
        self.cameras = tuple(cameras)
        # Both cameras' projections stacked, (4, 6): [p, 1] @ P = (d1 u1, d1 v1, d1, d2 u2, ...).
        self._projection = {
            n: np.vstack([c.projection_matrix(n) for c in self.cameras]).T for n in (False, True)
        }
        #: Both cameras as rows (2, 16) of :func:`envs.sensing.triangulation.camera_array`.
        self.camera_rows = np.stack([camera_array(c) for c in self.cameras])

    @property
    def pixel_projections(self) -> np.ndarray:
        """Both cameras' pixel projections stacked, (4, 6): [p, 1] @ P = (d1 u1, d1 v1, d1,
        d2 u2, d2 v2, d2)."""
        return self._projection[False]

    def project(self, points: np.ndarray, normalized: bool = False) -> np.ndarray:
        """World points (N, 3) -> (N, 4) pixels (or normalised coordinates) in both cameras."""
        return self.project_with_depth(points, normalized)[0]

    def project_with_depth(
        self, points: np.ndarray, normalized: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """Like :meth:`project`, also returning each point's depth in each camera, (N, 2) m
        (negative behind the camera)."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        P = self._projection[normalized]
        h = p @ P[:3] + P[3]  # (N, 6)
        depth = h[:, 2::3]  # (N, 2)
        return (h.reshape(-1, 2, 3)[..., :2] / depth[..., None]).reshape(-1, 4), depth

    def triangulate(self, pixels: np.ndarray, normalized: bool = False) -> np.ndarray:
        """(N, 4) pixels (or normalised coordinates) -> (N, 3) world points, linear least squares.

        Each camera gives two planes through its centre, (r_x + x r_z)·(p - c) = 0 and
        (r_y + y r_z)·(p - c) = 0; the four are solved for p in the least-squares sense
        (:func:`envs.sensing.triangulation.triangulate_elementwise`).
        """
        q = np.atleast_2d(np.asarray(pixels, dtype=float)).T  # (4, N)
        if pinhole_kernels.ENABLED:
            out = np.empty((q.shape[1], 3))
            try:
                pinhole_kernels.triangulate(self.camera_rows, q, normalized, out)
                return out
            except ZeroDivisionError:  # degenerate cameras: the numpy path's inf and NaN
                pass
        cameras = [camera_floats(c) for c in self.cameras]
        return np.stack(triangulate_elementwise(cameras, q, normalized), axis=-1)


class SphereSighting(NamedTuple):
    """What :meth:`StereoRig.sense_sphere` found of a sphere in both views."""

    pixels: np.ndarray  # (4,) px of the centre's image in the base images, NaN where not seen
    visible: np.ndarray  # (2,) bool, the sighting is trusted (see StereoRig.sense)
    framed: np.ndarray  # (2,) bool, the view shows the blob clear of its border
    blank: np.ndarray  # (2,) bool, the view shows no blob of the sphere's colour (find_blob)
    centre: np.ndarray  # (3,) m, the centre fitted to the trusted views (NaN if none)


class StereoRig(CameraPair):
    """The scene's two cameras (default ``cam_left``, ``cam_right``) at one image size.

    Args:
        model, data: a MuJoCo scene; camera poses are read from ``data`` (fixed cameras).
        height, width: sensing image size in pixels.

    Sensing keeps its last renderings (:class:`envs.sensing.render_memo.RenderMemo`) and does
    not draw views again whose scene has not changed; ``reuse_renders = False`` draws every
    one (the reference: the same sightings).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        height: int = 240,
        width: int = 320,
        cameras: Sequence[str] = ("cam_left", "cam_right"),
    ) -> None:
        if len(cameras) != 2:
            raise ValueError(f"a stereo rig needs two camera names, got {list(cameras)}")
        self.model, self.height, self.width = model, height, width
        #: The largest pixel coordinates (u, v) of an image, px.
        self.pixel_max = (float(width - 1), float(height - 1))
        self.camera_names = tuple(cameras)
        self.refresh(data)
        # Both cameras side by side in one buffer, rendered and read back together.
        self._renderer = ViewportRenderer(model, height, 2 * width, plane_grid=SENSING_PLANE_GRID)
        self.reuse_renders = True
        self._memo = RenderMemo()

    def refresh(self, data: mujoco.MjData) -> None:
        """Re-read both cameras from the model and ``data`` (after ``mj_forward``): after a change
        of camera pose or focal length, projection and triangulation follow the scene."""
        h, w = self.height, self.width
        super().__init__(
            [PinholeCamera.from_model(self.model, data, c, h, w) for c in self.camera_names]
        )

    @property
    def renders(self) -> tuple[int, int]:
        """How many renderings (read-backs) this rig has made, and how many camera views they
        drew (whole images or windows)."""
        return self._renderer.renders, self._renderer.views_drawn

    @property
    def reused(self) -> int:
        """How many renderings sensing took from the ones kept instead of drawing them."""
        return self._memo.reused

    def views(
        self,
        windows: Sequence[Window] | None = None,
        culls: Sequence[Window | None] | None = None,
    ) -> list[View]:
        """One :class:`View` per camera: its whole image, or the given windows; ``culls``: per
        camera, the part of its whole image whose pixels matter (:attr:`View.cull`), or None."""
        if windows is None:
            windows = [Window.full(self.height, self.width)] * 2
        if culls is None:
            culls = [None, None]
        return [
            View(name, cam.focal, cam.center, w, cull=c)
            for name, cam, w, c in zip(self.camera_names, self.cameras, windows, culls, strict=True)
        ]

    def sense(
        self,
        data: mujoco.MjData,
        marker: MarkerColour,
        radius: float | None = None,
        windows: Sequence[Window] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Render both cameras and find the image centre of one coloured sphere.

        Only the geom groups that a real camera would see for that marker are drawn: the reach
        task's target is sensed with the robot out of view, its effector marker with the robot
        (which may occlude it) but without the target (which it reaches and would otherwise
        hide); the grasp task's markers (``MarkerColour.together``) with everything in view.

        Without ``radius`` (the target) the centre comes from the blob's pixels
        (:func:`envs.sensing.marker_detection.find_sphere`: a blob cut by the border or not filling
        its hull is not visible). With the sphere's ``radius`` (m; the effector marker) it comes
        from the parts of the outline that are the sphere's own edge
        (:func:`envs.sensing.marker_detection.outline_edges`: not against a nearer occluder, not at
        the image border), fitted in both cameras at once with that radius
        (:func:`envs.sensing.marker_fit.locate`), so a partly hidden marker is still found. A
        camera's sighting counts only when the fit is trustworthy: at least
        ``marker_fit.MIN_OUTLINE_POINTS`` outline points within ``TRIM_PX`` of the fitted outline,
        RMS distance at most ``MAX_RMS_PX`` px, and the blob at least ``1 - MAX_HIDDEN`` of the
        whole sphere's image area (at most 90 % hidden); a sliver down to 2 % of it only beside a
        camera trusted on those terms, with an outline arc of at least ``MIN_SLIVER_ARC`` rad and a
        fitted radius that agrees with both views (:func:`envs.sensing.marker_fit.locate`). A
        sphere whose blob reaches the image border is cut by it and not seen in that camera,
        whatever the fit (its arc still helps to place it in the other camera).

        Args:
            windows: per camera, the part of its image to render (default: all of it); pixels
                are always reported in the base image's coordinates. Windows leave out the
                scene's static background (group 0, the floor): it lies behind the workspace,
                so it can neither hide a marker nor change its outline, and drawing it costs
                more than the rest of a small window.
        Returns:
            pixels (4,) of the sphere centre's image (NaN where not visible), visible (2,) bool.
        """
        return self.sense_many(data, (marker,), radius, windows)[0]

    def sense_many(
        self,
        data: mujoco.MjData,
        markers: Sequence[MarkerColour],
        radius: float | None = None,
        windows: Sequence[Window] | None = None,
        culls: Sequence[Window | None] | None = None,
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """:meth:`sense` of several spheres of different colours (all targets, or all on the
        arm, each of ``radius``), found in one rendering of both cameras: one (pixels (4,),
        visible (2,)) per marker, in their order. ``culls``: with whole images, per camera the
        part that holds every marker's image and a pixel round it, or None (:attr:`View.cull`:
        the same sightings, fewer geoms drawn)."""
        views, images = self._render(data, markers[0], windows, culls)
        if radius is not None:
            return [self._sphere(views, images, m, radius)[:2] for m in markers]
        found = []
        for marker in markers:
            pixels = np.full(4, np.nan)
            for k, ((rgb, _), view) in enumerate(zip(images, views, strict=True)):
                if view.window != Window.full(self.height, self.width):
                    raise ValueError("centroid sensing (no radius) needs whole images")
                sighting = find_sphere(rgb, marker, view.center, view.focal)
                if sighting is not None:
                    pixels[2 * k : 2 * k + 2] = sighting.uv
            found.append((pixels, np.isfinite(pixels[::2])))
        return found

    def sense_sphere(
        self,
        data: mujoco.MjData,
        marker: MarkerColour,
        radius: float,
        windows: Sequence[Window] | None = None,
    ) -> SphereSighting:
        """:meth:`sense` of a sphere of known ``radius`` (m), with what else the views showed
        (:class:`SphereSighting`): which views show its blob clear of their border (a larger
        view would show no more of it), which show none of it, and the fitted centre."""
        views, images = self._render(data, marker, windows)
        return self._sphere(views, images, marker, radius)

    def _sphere(
        self,
        views: list[View],
        images: list[tuple[np.ndarray, np.ndarray]],
        marker: MarkerColour,
        radius: float,
    ) -> SphereSighting:
        """The sphere of ``marker``'s colour and ``radius`` (m) in rendered views."""
        size = (self.height, self.width)
        outlines = [
            _outline(rgb, depth, marker, cam, view.window, radius, size)
            for (rgb, depth), cam, view in zip(images, self.cameras, views, strict=True)
        ]
        pixels, visible, centre = locate([o for o, _, _ in outlines], radius, self.triangulate)
        # A sphere cut by the image border is not seen, however well its arc fits.
        cut = np.array([cut for _, _, cut in outlines])
        visible = visible & ~cut
        pixels[np.repeat(cut, 2)] = np.nan
        framed = np.array([framed for _, framed, _ in outlines])
        blank = np.array([o is None for o, _, _ in outlines])
        return SphereSighting(pixels, visible, framed, blank, centre)

    def render_views(
        self, data: mujoco.MjData, groups: Sequence[int], windows: Sequence[Window] | None = None
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Both cameras' (RGB (h, w, 3) uint8, depth (h, w) m) images of the geom ``groups``:
        their whole images, or the given windows (:meth:`views`)."""
        return self._renderer.render(data, self.views(windows), groups)

    def _render(
        self,
        data: mujoco.MjData,
        marker: MarkerColour,
        windows: Sequence[Window] | None,
        culls: Sequence[Window | None] | None = None,
    ) -> tuple[list[View], list[tuple[np.ndarray, np.ndarray]]]:
        """The views and their (RGB, depth) images, drawing the marker's geom groups."""
        groups: tuple[int, ...]
        if marker.together:  # the grasp task: the object and the robot in the same images
            groups = (GROUP_TARGET, GROUP_ROBOT, GROUP_MARKER)
        elif marker.is_target:
            groups = (GROUP_TARGET,)
        else:
            groups = (GROUP_ROBOT, GROUP_MARKER)
        if windows is None:  # whole images show the scene; windows skip its static background
            groups = (GROUP_SCENE, *groups)
        views = self.views(windows, culls)
        if not self.reuse_renders:
            return views, self._renderer.render(data, views, groups)
        key = self._memo.key(self.model, data, groups, views)
        return views, self._memo.get(key, lambda: self._renderer.render(data, views, groups))

    def close(self) -> None:
        self._renderer.close()
        self._memo.clear()


def _outline(
    rgb: np.ndarray,
    depth: np.ndarray,
    marker: MarkerColour,
    camera: PinholeCamera,
    window: Window,
    radius: float,
    size: tuple[int, int],
) -> tuple[CameraOutline | None, bool, bool]:
    """What one camera's view shows of the marker sphere (``radius`` m), in base pixels (None:
    no blob), whether the blob is clear of the view's border, and whether it is cut by the
    border of the base image of ``size`` (height, width) px (it reaches a side of the view that
    lies on that border)."""
    blob = find_blob(rgb, marker, whole=True)
    if blob is None:
        return None, False, False
    left, top, right, bottom = window.on_image_border(*size)
    m = blob.mask
    cut = (
        (left and m[:, 0].any())
        or (top and m[0].any())
        or (right and m[:, -1].any())
        or (bottom and m[-1].any())
    )
    edges = outline_edges(blob, depth, OUTLINE_DEPTH_MARGIN * radius)  # (m, 2) window px
    centroid, covariance = pixel_moments(blob.mask)  # window px
    centroid = window.to_base(centroid[:1], centroid[1:])[0]
    covariance /= window.density**2  # base px²
    start = perspective_centre(centroid, covariance, camera.center, camera.focal)
    area = blob.count / window.density**2  # base px²
    outline = CameraOutline(camera, window.to_base(edges[:, 0], edges[:, 1]), area, start)
    return outline, not blob.touches_border, bool(cut)
