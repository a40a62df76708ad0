"""A sphere of known radius located from the visible parts of its outline in two cameras.

Every outline point seen by camera k (centre O_k) gives a ray d (unit). The ray grazes a sphere of
radius R at centre C exactly when d·(C - O_k) = √(|C - O_k|² - R²): the outline is the cone of
rays at the half-angle asin(R / |C - O_k|) about the direction to C. C (3 numbers) is fitted to the
outline points of both cameras by Gauss-Newton on that residual, so an occluder that hides part of
the outline only removes points; the points left still pin the cone, whose size is set by R and
the distance that the two views triangulate. The sphere centre's image in each camera is then the
projection of C.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from envs.sensing import kernels as sensing_kernels

MAX_ITERATIONS, CONVERGED_STEP = 20, 1e-7
#: Outline points farther than this (px) from the fitted outline are dropped and the fit redone
#: (an occluder's edge taken for the sphere's).
TRIM_PX = 1.0
#: A camera's sighting is trusted when, after trimming, it keeps at least MIN_OUTLINE_POINTS
#: points, their RMS distance to the fitted outline is at most MAX_RMS_PX (base pixels), and the
#: blob covers at least 1 - MAX_HIDDEN of the area of the whole sphere's image at C.
MIN_OUTLINE_POINTS = 8
MAX_RMS_PX = 0.6
MAX_HIDDEN = 0.9
#: A sliver (a blob covering less than 1 - MAX_HIDDEN of the sphere's image, but at least
#: 1 - MAX_HIDDEN_SLIVER) is trusted too when the fit of both cameras agrees with the geometry:
#: the other camera is trusted on the terms above, the sliver's points (at least
#: MIN_OUTLINE_POINTS, RMS at most MAX_RMS_PX) span at least MIN_SLIVER_ARC rad of the outline
#: about the centre's image, and the radius fitted to both views is within RADIUS_TOL of the
#: sphere's (so the distance the views triangulate agrees with the outline's size in each).
MAX_HIDDEN_SLIVER = 0.98
MIN_SLIVER_ARC = 0.8
RADIUS_TOL = 0.03


class OutlineCamera(Protocol):
    """What the fit needs of a camera (:class:`envs.sensing.stereo.PinholeCamera` has it)."""

    @property
    def position(self) -> np.ndarray: ...  # (3,) world, m

    @property
    def rotation(self) -> np.ndarray: ...  # (3, 3) columns = camera x, y, z in world

    @property
    def focal(self) -> np.ndarray: ...  # (2,) px per unit of normalised coordinate

    @property
    def pixel_projection(self) -> np.ndarray: ...  # (3, 4)

    def to_normalized(self, uv: np.ndarray) -> np.ndarray: ...

    def project(self, points: np.ndarray) -> np.ndarray: ...

    def sphere_area(self, centres: np.ndarray, radius: float) -> np.ndarray: ...


#: The rig's triangulation: pixels (N, 4) -> world points (N, 3) m.
Triangulate = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class CameraOutline:
    """What one camera saw of the sphere: outline points and blob area, in base pixels."""

    camera: OutlineCamera
    points: np.ndarray  # (m, 2) px, outline points on the sphere's own edge
    area: float  # px², pixels of the blob (in base pixels)
    start: np.ndarray  # (2,) px, a first guess of the centre's image (from the blob's pixels)


def rays(camera, uv: np.ndarray) -> np.ndarray:
    """Unit world directions (m, 3) of pixels uv (m, 2) from the camera centre."""
    xy = camera.to_normalized(uv)
    local = np.column_stack([xy, -np.ones(len(xy))])  # camera looks along -z
    d = local @ camera.rotation.T
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def fit_centre(
    origins: Sequence[np.ndarray], directions: Sequence[np.ndarray], radius: float, start
) -> tuple[np.ndarray, float]:
    """C (3,) m and the outline's radius R (m) minimising Σ (d·(C - O) - √(|C - O|² - R²))²
    over the outline rays of every camera (origins (3,) each, directions (m_k, 3) each), from
    ``start`` (3,) and ``radius``.

    With two cameras R is fitted too: the outline that the colour threshold finds is a little
    smaller than the sphere (its darkest rim pixels drop out), and a fixed R would turn that
    into a wrong distance and so a wrong centre in both images. The distance then comes from the
    two views (triangulation) and R sets the outline's size in each. With one camera R is fixed.
    With numba (``sensing_kernels.ENABLED``) the iterations run compiled.
    """
    centres = np.concatenate(
        [np.broadcast_to(o, d.shape) for o, d in zip(origins, directions, strict=True)]
    )
    D = np.concatenate(directions)  # (m, 3)
    x = np.append(np.asarray(start, dtype=float), radius)  # (C, R)
    free = 4 if len(origins) > 1 else 3
    if sensing_kernels.ENABLED:
        fitted, ok = sensing_kernels.fit_centre(centres, D, x, free, MAX_ITERATIONS, CONVERGED_STEP)
        if ok:  # else singular normal equations: the numpy path's least squares
            return fitted[:3], float(fitted[3])
    for _ in range(MAX_ITERATIONS):
        v = x[:3] - centres  # (m, 3) from each ray's camera centre
        tangent = np.sqrt(np.maximum(np.einsum("ij,ij->i", v, v) - x[3] ** 2, 1e-12))  # (m,)
        r = np.einsum("ij,ij->i", D, v) - tangent
        J = np.empty((len(D), 4))
        J[:, :3] = D - v / tangent[:, None]
        J[:, 3] = x[3] / tangent
        J = J[:, :free]
        try:  # normal equations: (free, free), several times cheaper than lstsq on (m, free)
            step = np.linalg.solve(J.T @ J, -(J.T @ r))
        except np.linalg.LinAlgError:
            step = np.linalg.lstsq(J, -r, rcond=None)[0]
        x[:free] += step
        if step @ step < CONVERGED_STEP**2:
            break
    return x[:3], float(x[3])


def outline_residual_px(
    camera, centre: np.ndarray, radius: float, uv: np.ndarray, d: np.ndarray | None = None
) -> np.ndarray:
    """Distance (m,) px from each point uv (m, 2) to the outline of the sphere (centre (3,) m),
    along the outline's normal through that point (negative inside); ``d`` (m, 3): the points'
    :func:`rays`, if known."""
    d = rays(camera, uv) if d is None else d
    if sensing_kernels.ENABLED:
        return sensing_kernels.outline_residual_px(
            camera.pixel_projection, camera.position, centre, radius, uv, d
        )
    axis = centre - camera.position
    dist = float(np.linalg.norm(axis))
    axis = axis / dist
    alpha = np.arcsin(min(radius / dist, 1.0))
    across = d - (d @ axis)[:, None] * axis
    across /= np.maximum(np.linalg.norm(across, axis=1, keepdims=True), 1e-12)
    on_outline = np.cos(alpha) * axis + np.sin(alpha) * across  # (m, 3), grazing rays
    edge = camera.project(camera.position + on_outline)  # (m, 2)
    centre_px = camera.project(centre[None])[0]
    outward = edge - centre_px
    outward /= np.maximum(np.linalg.norm(outward, axis=1, keepdims=True), 1e-12)
    return ((uv - edge) * outward).sum(1)


def locate(
    outlines: Sequence[CameraOutline | None], radius: float, triangulate: Triangulate
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The sphere centre's image in each camera from what the cameras saw.

    The fit uses every camera with enough outline points; if one of them is then not trusted
    (say a sliver of the sphere with an occluder's edge in it), it is fitted again without that
    camera (without the one that saw least, if none is trusted).

    How "visible" (trusted) is decided, per camera: after trimming, at least MIN_OUTLINE_POINTS
    outline points at an RMS distance of at most MAX_RMS_PX from the fitted outline, and a blob
    of at least 1 - MAX_HIDDEN (10 %) of the sphere's image. A sliver, down to
    1 - MAX_HIDDEN_SLIVER (2 %) of it, is trusted only beside a camera trusted on those terms,
    when its points span at least MIN_SLIVER_ARC rad of the outline and the radius fitted to
    both views is within RADIUS_TOL of the sphere's: the other camera then fixes the centre's
    direction, and the sliver's arc, which must agree with it, the distance along that ray.

    Args:
        outlines: per camera, its outline (None: no blob).
        radius: the sphere's radius, m.
        triangulate: (1, 4) px -> (1, 3) world (the rig's), for the first guess.
    Returns:
        pixels (2 * cameras,) (NaN where not trusted), trusted (cameras,) bool, and the fitted
        centre C (3,) m of the trusted cameras' fit (NaN if none is trusted; from one camera,
        its distance rests on the outline's size alone). See the module constants for when a
        camera's sighting is trusted.
    """
    n = len(outlines)
    pixels, trusted = np.full(2 * n, np.nan), np.zeros(n, dtype=bool)
    present = {
        k: o
        for k, o in enumerate(outlines)
        if o is not None and len(o.points) >= MIN_OUTLINE_POINTS
    }
    used = list(present)
    while used:
        result = _fit({k: present[k] for k in used}, radius, triangulate)
        if result is None:
            ok = dict.fromkeys(used, False)
        else:
            centre, ok = result
            if all(ok.values()):
                for k in used:
                    pixels[2 * k : 2 * k + 2] = present[k].camera.project(centre[None])[0]
                    trusted[k] = True
                return pixels, trusted, centre
        kept = [k for k in used if ok[k]]
        # None trusted: the camera that saw least may have spoilt the fit; try without it.
        used = kept or sorted(used, key=lambda k: present[k].area)[1:]
    return pixels, trusted, np.full(3, np.nan)


def _fit(
    outlines: dict[int, CameraOutline], radius: float, triangulate: Triangulate
) -> tuple[np.ndarray, dict[int, bool]] | None:
    """Fit C to the outlines of the cameras (by index); C and whether each camera is trusted."""
    used = list(outlines)
    if len(used) == 2:
        start = triangulate(np.concatenate([outlines[k].start for k in used])[None])[0]
    else:  # one camera: distance from the blob's size, r_px ≈ f R / distance
        o = outlines[used[0]]
        distance = o.camera.focal[0] * radius * np.sqrt(np.pi / max(o.area, 1.0))
        start = o.camera.position + distance * rays(o.camera, o.start[None])[0]
    points = {k: outlines[k].points for k in used}
    directions = {k: rays(outlines[k].camera, points[k]) for k in used}
    residuals: dict[int, np.ndarray] = {}  # px, of the points kept, to the last fit
    centre, outline_radius = start, radius
    for _ in range(2):  # fit, drop the points that are not on the outline, fit again
        if min(len(p) for p in points.values()) < MIN_OUTLINE_POINTS:
            break
        centre, outline_radius = fit_centre(
            [outlines[k].camera.position for k in used],
            [directions[k] for k in used],
            radius,
            centre,
        )
        dropped = False
        for k in used:
            residual = outline_residual_px(
                outlines[k].camera, centre, outline_radius, points[k], directions[k]
            )
            keep = np.abs(residual) <= TRIM_PX
            dropped = dropped or not keep.all()
            points[k], directions[k], residuals[k] = (
                points[k][keep],
                directions[k][keep],
                residual[keep],
            )
        if not dropped:  # fitting the same points again would give the same fit
            break
    if not np.all(np.isfinite(centre)):
        return None
    fitted, share = {}, {}  # outline fits; share of the sphere's image the blob covers
    for k in used:
        o, p = outlines[k], points[k]
        rms = np.sqrt(np.mean(residuals[k] ** 2)) if len(p) >= MIN_OUTLINE_POINTS else np.inf
        fitted[k] = bool(rms <= MAX_RMS_PX)
        image_area = o.camera.sphere_area(centre[None], radius)[0]
        # A centre fitted within a radius of the camera has no image: no sighting to trust.
        share[k] = o.area / image_area if image_area > 0.0 else 0.0
    own = {k: fitted[k] and share[k] >= 1.0 - MAX_HIDDEN for k in used}  # trusted on its own
    ok = dict(own)
    if len(used) == 2 and abs(outline_radius / radius - 1.0) <= RADIUS_TOL:
        a, b = used
        for k, other in ((a, b), (b, a)):
            if not own[k] and own[other] and fitted[k] and share[k] >= 1.0 - MAX_HIDDEN_SLIVER:
                ok[k] = outline_arc(outlines[k].camera, centre, points[k]) >= MIN_SLIVER_ARC
    return centre, ok


def outline_arc(camera, centre: np.ndarray, uv: np.ndarray) -> float:
    """The angle (rad, 0 to 2π) that points uv (m, 2) px span about the image of ``centre``
    (3,) m: 2π less the widest angular gap between neighbouring points."""
    offset = uv - camera.project(centre[None])[0]
    angles = np.sort(np.arctan2(offset[:, 1], offset[:, 0]))
    gaps = np.diff(angles, append=angles[0] + 2.0 * np.pi)
    return float(2.0 * np.pi - gaps.max())
