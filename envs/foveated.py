"""Foveated stereo sensing: each camera renders only a small window around where the marker is
expected, at a higher pixel density than its base image, and reports base-image pixels.

A window is an off-centre frustum of the same camera (:class:`envs.viewports.Window`), so the
marker is found with the outline fit of :func:`envs.sphere_fit.locate` at ``density`` times the
base resolution while both windows together have fewer pixels than one base image. Where the
marker is expected comes from the caller (for the effector: the target's pixels, which a reaching
controller aims at); if it is not found there, both whole base images are rendered, and the
windows are placed where the whole images found it.
"""

from __future__ import annotations

import numpy as np

from envs.stereo import StereoRig
from envs.viewports import Window

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


class FoveatedSensing:
    """Senses a sphere of known radius through windows of a :class:`StereoRig`'s cameras.

    Args:
        stereo: the rig (its image size is the base image).
        density: window pixels per base pixel; margin: see FOVEA_MARGIN_PX.
    """

    def __init__(
        self, stereo: StereoRig, density: float = FOVEA_DENSITY, margin: float = FOVEA_MARGIN_PX
    ) -> None:
        if not density >= 1.0:
            raise ValueError(f"density is window pixels per base pixel, >= 1, got {density!r}")
        self.stereo, self.density, self.margin = stereo, float(density), float(margin)
        self.fallbacks = 0  # calls that had to render the whole images

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
            size = min(2 * (major[k] + self.margin), st.width, st.height)  # base px
            left = float(np.clip(uv[0] - size / 2, -0.5, st.width - 0.5 - size))
            top = float(np.clip(uv[1] - size / 2, -0.5, st.height - 0.5 - size))
            pixels = min(int(np.ceil(size * self.density)), st.height)  # fits the buffer
            out.append(Window(left, top, pixels, pixels, pixels / size, depth[k]))
        return out

    def sense(
        self, data, marker, radius: float, expected: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (4,) of the sphere centre in the base images (NaN where not visible) and
        visible (2,) bool, from windows about ``expected`` (4,) px; whole images first if
        ``expected`` is None or the marker is not in its windows.

        A camera whose window shows the marker's blob clear of the window's border but not
        trusted (a sliver, its outline hidden) is not rendered whole: the whole image would show
        the same part of the marker at a lower density."""
        if expected is not None and np.any(np.isfinite(expected)):
            pixels, visible, framed = self.stereo.sense_sphere(
                data, marker, radius, self.windows(expected, radius)
            )
            if np.all(visible | framed):
                return pixels, visible
        self.fallbacks += 1
        whole, seen = self.stereo.sense(data, marker, radius)
        if not seen.any():
            return whole, seen
        pixels, visible = self.stereo.sense(data, marker, radius, self.windows(whole, radius))
        if visible.sum() < seen.sum():
            return whole, seen
        return pixels, visible
