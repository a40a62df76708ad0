"""Foveated stereo sensing: each camera renders only a small window around where the marker is
expected, at a higher pixel density than its base image, and reports base-image pixels.

A window is an off-centre frustum of the same camera (:class:`envs.sensing.viewports.Window`), so
the marker is found with the outline fit of :func:`envs.sensing.marker_fit.locate` at ``density``
times the base resolution while both windows together have fewer pixels than one base image. Where
the marker is expected comes from the caller (for the effector: the target's pixels, which a
reaching controller aims at); if it is not found there, both whole base images are rendered, and the
windows are placed where the whole images found it. A window that shows none of the marker
while the other camera's sighting places it inside that window has shown where it is (hidden
behind the robot), so the whole images are not rendered for it (:meth:`FoveatedSensing.hidden`).

Every window lies on one grid of 1/density base pixels (its edges and its pixels), wherever it is
placed: a sphere at one place is drawn on the same pixels, so it is sensed at the same pixels
whichever prediction placed its window. The marker that reaches the target is then sensed where
the target was (both are spheres of one radius, in mirrored colours), and a controller that
servos the marker's pixels onto the target's cancels the share of the sensing error the two have
in common (the part the robot's links hide of the marker stays its own).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from envs.sensing.marker_fit import rays
from envs.sensing.stereo import SphereSighting, StereoRig
from envs.sensing.viewports import Window

if TYPE_CHECKING:
    import mujoco  # imported at run time only where used: envs picks the GL back-end first

#: Window pixels per base-image pixel (each axis).
FOVEA_DENSITY = 4.0
#: Window half-size beyond the marker image's expected radius, base pixels: room for the
#: prediction's error.
FOVEA_MARGIN_PX = 5.0
#: How much deeper than expected (m along the optical axis) the marker may be: geoms wholly
#: beyond the expected depth + radius + this are not drawn in the window.
FOVEA_DEPTH_MARGIN = 0.1
#: The marker image's semi-axis, as a share of the image height, assumed when only one camera
#: has seen it (its distance unknown).
FALLBACK_MAJOR = 0.05
#: A window showing none of the marker has it hidden when the marker's image lies inside the
#: window for every distance along the other camera's ray from (1 - HIDDEN_DEPTH_SHARE) × the
#: nearer to (1 + HIDDEN_DEPTH_SHARE) × the farther of two estimates: the other camera's
#: outline fit and the expected position. The two are independent (the marker's outline size,
#: the target's sensing); a one-camera fit's distance is within 0.6 % (PUMA) and 1.2 % (RIACS)
#: of the true one in 90 % of windowed fits, off by up to 9 % and 15 % in the rest (734 and
#: 393 fits near the target), so each alone would not do.
HIDDEN_DEPTH_SHARE = 0.01
#: ... with the image's bounding box this far (base px) inside the window's border.
HIDDEN_BORDER_PX = 1.0
#: A sphere whose image lies this far (base px) beyond every camera's window, or farther,
#: cannot draw a pixel in them (room for rasterisation; the image's extent is bounded
#: generously, :meth:`FoveatedSensing.can_show`).
BLIND_MARGIN_PX = 2.0
#: Base px added round the part of a whole image whose pixels a sighting reads before geoms are
#: culled to it (:meth:`FoveatedSensing.regions`): the culling frustum comes from the pinhole
#: intrinsics, the drawing from MuJoCo's own, and the two differ by about a pixel.
CULL_MARGIN_PX = 8.0


class FoveatedSensing:
    """Senses a sphere of known radius through windows of a :class:`StereoRig`'s cameras.

    Args:
        stereo: the rig (its image size is the base image).
        density: window pixels per base pixel; margin: see FOVEA_MARGIN_PX.
        skip_blind: given where the spheres are (``centres`` of :meth:`sense_many`), do not
            render windows that cannot show them (:meth:`can_show`): the whole images are
            rendered at once, as after windows that showed nothing; and draw in the whole
            images only the geoms that can reach near the spheres' images (:meth:`regions`).
            The same sightings; False renders every window and geom (the reference).
    """

    def __init__(
        self,
        stereo: StereoRig,
        density: float = FOVEA_DENSITY,
        margin: float = FOVEA_MARGIN_PX,
        skip_blind: bool = True,
    ) -> None:
        if not density >= 1.0:
            raise ValueError(f"density is window pixels per base pixel, >= 1, got {density!r}")
        self.stereo, self.density, self.margin = stereo, float(density), float(margin)
        self.skip_blind = skip_blind
        self.fallbacks = 0  # calls that had to render the whole images
        self.skipped = 0  # windows not rendered: they could not show the sphere

    def windows(self, expected: np.ndarray, radius: float) -> list[Window]:
        """One window per camera about the expected centre ``expected`` (4,) base px; a camera
        whose entry is NaN gets its whole image. The window stays inside the base image."""
        st = self.stereo
        full = Window.full(st.height, st.width)
        guess = np.asarray(expected, dtype=float)
        if np.all(np.isfinite(guess)):
            centre = st.triangulate(guess[None])  # (1, 3)
            major = [c.sphere_semi_axes(centre, radius)[0, 0] for c in st.cameras]  # px
            # depth along each optical axis (the camera looks along -z), and room beyond it
            depth = [
                float((c.position - centre[0]) @ c.rotation[:, 2]) + radius + FOVEA_DEPTH_MARGIN
                for c in st.cameras
            ]
        else:  # one camera: the distance is not known
            major = [FALLBACK_MAJOR * st.height] * 2
            depth = [np.inf] * 2
        out = []
        for k in range(2):
            uv = guess[2 * k : 2 * k + 2]
            if not np.all(np.isfinite(uv)):
                out.append(full)
                continue
            wanted = min(2 * (major[k] + self.margin), st.width, st.height)  # base px
            pixels = min(math.ceil(wanted * self.density), st.height)  # fits the buffer
            size = pixels / self.density  # base px, so that the window's density is exact
            left = self._on_grid(float(uv[0]) - size / 2, size, st.width)
            top = self._on_grid(float(uv[1]) - size / 2, size, st.height)
            out.append(Window(left, top, pixels, pixels, self.density, depth[k]))
        return out

    def _on_grid(self, edge: float, size: float, extent: int) -> float:
        """The window edge (base px) nearest ``edge`` on the grid of 1/density base px that
        starts at the image's edge (-0.5), with the window inside [-0.5, extent - 0.5]."""
        steps = round((edge + 0.5) * self.density)
        last = math.floor((extent - size) * self.density + 1e-9)  # the last edge inside
        return -0.5 + min(max(steps, 0), last) / self.density

    def sense(
        self, data: mujoco.MjData, marker, radius: float, expected: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (4,) of the sphere centre in the base images (NaN where not visible) and
        visible (2,) bool, from windows about ``expected`` (4,) px; whole images first if
        ``expected`` is None or the marker is not in its windows.

        A camera's whole image is not rendered when its window already showed all that the
        whole image could: when the window shows the marker's blob clear of its border but not
        trusted (a sliver, its outline hidden; the whole image would show the same part at a
        lower density), or when it shows none of the marker while the other camera's trusted
        sighting places the marker inside the window (:meth:`hidden`)."""
        return self.sense_many(data, (marker,), radius, expected)[0]

    def sense_many(
        self,
        data: mujoco.MjData,
        markers,
        radius: float,
        expected: np.ndarray | None = None,
        centres: np.ndarray | None = None,
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """:meth:`sense` of several spheres of one ``radius`` drawn with the same geom groups
        (one task's target markers, or its arm's), ``expected`` (4M,) px or None: each in its
        own windows first; the whole images, where some are needed, rendered once for all the
        markers that need them. The same sightings as :meth:`sense` marker by marker, with
        fewer renderings.

        ``centres`` (M, 3) m, where the spheres are (or None): with ``skip_blind``, windows
        that cannot show a sphere (:meth:`can_show`) are not rendered; they would show none of
        it, and the whole images would be rendered after them all the same."""
        found: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(markers)
        pending = []
        for k, marker in enumerate(markers):
            guess = None if expected is None else expected[4 * k : 4 * k + 4]
            if guess is not None and np.any(np.isfinite(guess)):
                windows = self.windows(guess, radius)
                if self.skip_blind and centres is not None:
                    if not self.can_show(windows, centres[k], radius):
                        self.skipped += 1
                        pending.append(k)
                        continue
                seen = self.stereo.sense_sphere(data, marker, radius, windows)
                if np.all(seen.visible | seen.framed | self.hidden(seen, windows, guess, radius)):
                    found[k] = (seen.pixels, seen.visible)
                    continue
            pending.append(k)
        self.fallbacks += len(pending)
        culls = None
        if self.skip_blind and centres is not None and pending:
            culls = self.regions(centres[pending], radius)
        wholes = (
            self.stereo.sense_many(data, [markers[k] for k in pending], radius, culls=culls)
            if pending
            else []
        )
        for k, (whole, whole_visible) in zip(pending, wholes, strict=True):
            found[k] = (whole, whole_visible)
            if whole_visible.any():
                windows = self.windows(whole, radius)
                pixels, visible = self.stereo.sense(data, markers[k], radius, windows)
                if visible.sum() >= whole_visible.sum():
                    found[k] = (pixels, visible)
        return found  # type: ignore[return-value]

    def can_show(self, windows: list[Window], centre: np.ndarray, radius: float) -> bool:
        """Whether a sphere of ``radius`` (m) at ``centre`` (3,) m may draw a pixel in one of
        the cameras' ``windows``. False only when, in both cameras, it lies in front of the
        camera and a square about its centre's image, 2 semi-major axes of its image plus
        BLIND_MARGIN_PX from it, misses the window: the image (an ellipse holding the centre's
        image) is then wholly outside the window, and so is the sphere's drawn mesh (its
        vertices lie on the sphere)."""
        for camera, w in zip(self.stereo.cameras, windows, strict=True):
            if (camera.position - centre) @ camera.rotation[:, 2] <= radius:
                return True  # reaches the camera's plane: not decided here
            uv = camera.project(centre[None])[0]  # (2,) px
            reach = 2.0 * camera.sphere_semi_axes(centre[None], radius)[0, 0] + BLIND_MARGIN_PX
            right, bottom = w.left + w.width / w.density, w.top + w.height / w.density
            if (
                uv[0] + reach >= w.left
                and uv[0] - reach <= right
                and uv[1] + reach >= w.top
                and uv[1] - reach <= bottom
            ):
                return True
        return False

    def regions(self, centres: np.ndarray, radius: float) -> list[Window | None]:
        """Per camera, the part of its whole image (density 1) whose pixels a sighting of
        spheres of ``radius`` (m) at ``centres`` (M, 3) m reads: the squares of
        :meth:`can_show` about their images, widened by CULL_MARGIN_PX (geoms are culled with
        the pinhole intrinsics, drawn with MuJoCo's own frustum). None where a sphere reaches
        the camera's plane or none of the squares meets the image (nothing culled there)."""
        st = self.stereo
        out: list[Window | None] = []
        for camera in st.cameras:
            if np.any((camera.position - centres) @ camera.rotation[:, 2] <= radius):
                out.append(None)
                continue
            uv = camera.project(centres)  # (M, 2) px
            reach = 2.0 * camera.sphere_semi_axes(centres, radius)[:, :1] + BLIND_MARGIN_PX
            low, high = (uv - reach).min(axis=0), (uv + reach).max(axis=0)  # (2,) px
            if np.any(high < -0.5) or np.any(low > [st.width - 0.5, st.height - 0.5]):
                out.append(None)
                continue
            low = low - CULL_MARGIN_PX
            size = np.ceil(high - low + CULL_MARGIN_PX)
            out.append(Window(float(low[0]), float(low[1]), int(size[0]), int(size[1])))
        return out

    def hidden(
        self, seen: SphereSighting, windows: list[Window], expected: np.ndarray, radius: float
    ) -> np.ndarray:
        """Per camera (2,) bool: its window shows none of the marker although the marker lies
        inside it, so the marker is hidden from that camera (behind the robot) and its whole
        image would show no more.

        Decided only when the other camera's sighting is trusted and the blind camera's window
        shows no blob of the marker's colour. The marker then lies on the other camera's ray
        through its sighting; its distance along that ray is taken between the nearer and the
        farther of the other camera's outline fit (the outline's size) and the expected position
        (``expected`` (4,) px, triangulated), widened by HIDDEN_DEPTH_SHARE each way. The
        marker counts as inside the window when, at both ends of that stretch of the ray (and
        so all along it: the window is convex, the image of the stretched sphere is the hull of
        the two ends' images), the bounding box of the sphere's image lies HIDDEN_BORDER_PX
        inside the window and the sphere is nearer than the window's depth (so it was drawn).
        A misplaced window (the marker elsewhere, or the two distance estimates far apart)
        fails this, and the caller renders the whole images.
        """
        out = np.zeros(2, dtype=bool)
        guess = np.asarray(expected, dtype=float)
        if seen.visible.sum() != 1 or not np.all(np.isfinite(guess)):
            return out
        j = int(np.flatnonzero(seen.visible)[0])
        k = 1 - j
        if not seen.blank[k]:
            return out
        seer, blind, w = self.stereo.cameras[j], self.stereo.cameras[k], windows[k]
        ray = rays(seer, seen.pixels[2 * j : 2 * j + 2][None])[0]  # (3,) unit
        point = self.stereo.triangulate(guess[None])[0]
        distances = [(seen.centre - seer.position) @ ray, (point - seer.position) @ ray]  # m
        near = min(distances) * (1.0 - HIDDEN_DEPTH_SHARE)
        far = max(distances) * (1.0 + HIDDEN_DEPTH_SHARE)
        if not near > radius:
            return out
        ends = seer.position + np.outer([near, far], ray)  # (2, 3) m
        uv = blind.project(ends)  # (2, 2) base px
        half = blind.sphere_semi_axes(ends, radius)[:, :1] + HIDDEN_BORDER_PX  # (2, 1) px
        low = np.array([w.left, w.top])
        high = low + np.array([w.width, w.height]) / w.density
        depth = (blind.position - ends) @ blind.rotation[:, 2] + radius  # (2,) m
        out[k] = bool(
            np.all(uv - half >= low) and np.all(uv + half <= high) and np.all(depth <= w.depth)
        )
        return out
