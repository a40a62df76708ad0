"""Finding a coloured sphere in a camera image: its blob, the centre of its perspective image
from the blob's pixels, and the blob's edges that are the sphere's own outline.

The image of a sphere is an ellipse whose major axis lies on the ray from the principal point;
its ends are the projections of the tangent directions φ - α and φ + α, where φ is the off-axis
angle of the sphere's centre. The blob's centroid is the midpoint of those ends, displaced outward
from tan φ (several pixels at 75° off axis), so the centre is recovered as tan of their angular
mean: φ = (atan ρ1 + atan ρ2) / 2.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from envs.sensing import kernels as sensing_kernels

MIN_BLOB_PIXELS = 4
#: A blob covering less of its convex hull than this is taken as partly occluded: not visible
#: (centroid sensing of the target, which is sensed with the robot out of view).
MIN_FILL_RATIO = 0.7


@dataclass(frozen=True)
class MarkerColour:
    """An HSV window (OpenCV scale: H 0-179, S and V 0-255) that selects one marker's pixels."""

    name: str
    is_target: bool
    hue_ranges: tuple[tuple[int, int], ...]
    min_saturation: int = 120
    min_value: int = 40
    #: Sensed in images of the whole scene, the target and the robot together (the grasp task),
    #: instead of the target with the robot out of view and the arm's markers without the
    #: target (the reach task, whose marker and target coincide at the goal).
    together: bool = False

    def mask(self, rgb: np.ndarray) -> np.ndarray:
        hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
        masks = [
            cv2.inRange(hsv, (lo, self.min_saturation, self.min_value), (hi, 255, 255))
            for lo, hi in self.hue_ranges
        ]
        for other in masks[1:]:
            np.bitwise_or(masks[0], other, out=masks[0])
        return masks[0]


RED_HUES, GREEN_HUES, BLUE_HUES = ((0, 8), (172, 179)), ((45, 75),), ((105, 135),)
#: The hand's colours of the grasp task (rgba 0.9/0.1 mixtures: hue 30, 90 and 150), between
#: the object's windows.
YELLOW_HUES, CYAN_HUES, MAGENTA_HUES = ((22, 38),), ((82, 98),), ((142, 158),)
RED_TARGET = MarkerColour("target", True, RED_HUES)
GREEN_EFFECTOR = MarkerColour("effector", False, GREEN_HUES, min_value=10)
#: The grasp task's markers: the object's red, green and blue
#: (``models.puma560.grasp.MARKER_COLOURS``), sensed at reset, and the hand's yellow, cyan and
#: magenta (``HAND_COLOURS``), sensed after every move, all in images of the whole scene. The
#: floor and the robot are grey (saturation far below ``min_saturation``), the object's handle
#: a pale sand.
GRASP_OBJECT = tuple(
    MarkerColour(f"object_{name}", True, hues, together=True)
    for name, hues in (("red", RED_HUES), ("green", GREEN_HUES), ("blue", BLUE_HUES))
)
GRASP_HAND = tuple(
    MarkerColour(f"hand_{name}", False, hues, min_value=10, together=True)
    for name, hues in (("yellow", YELLOW_HUES), ("cyan", CYAN_HUES), ("magenta", MAGENTA_HUES))
)


@dataclass(frozen=True)
class Sighting:
    """One camera's sighting of a sphere: its centre's image and the blob's size."""

    uv: np.ndarray  # (2,) pixel of the projected sphere centre
    area: float  # px², blob with its convex hull filled


@dataclass(frozen=True)
class Blob:
    """The largest connected region of a marker's colour in an image (image pixels)."""

    mask: np.ndarray  # (h, w) bool, the region
    count: int  # pixels in the region
    touches_border: bool


def find_blob(rgb: np.ndarray, colour: MarkerColour, whole: bool = False) -> Blob | None:
    """The largest 8-connected region of ``colour`` in ``rgb`` (h, w, 3), or None if there is
    none of at least MIN_BLOB_PIXELS pixels. ``whole``: all regions of that colour together
    (a marker cut in two by a thin link in front of it), with their holes filled, or None if
    they have fewer than MIN_BLOB_PIXELS pixels together."""
    mask = colour.mask(rgb)
    height, width = mask.shape
    if whole:  # every region, holes (the specular highlight, unsaturated) filled
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        if not contours:
            return None
        filled = np.zeros_like(mask)
        cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
        x, y, w, h = cv2.boundingRect(np.concatenate(contours))
        count = cv2.countNonZero(filled)
        if count < MIN_BLOB_PIXELS:
            return None
        border = x == 0 or y == 0 or x + w >= width or y + h >= height
        return Blob(filled > 0, int(count), bool(border))
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if count < 2:
        return None
    best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    x, y, w, h, area = stats[best]
    if area < MIN_BLOB_PIXELS:
        return None
    border = x == 0 or y == 0 or x + w >= width or y + h >= height
    return Blob(labels == best, int(area), bool(border))


def outline_edges(blob: Blob, depth: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """Points (m, 2) (column, row; fractional image pixels) on the blob's outline where the
    sphere's own edge is seen: between a blob pixel and a 4-neighbour outside the blob that is
    more than ``margin`` farther from the camera (the background, or the robot behind the
    sphere). Edges against a nearer neighbour (an occluder in front), against a surface that
    meets the sphere (a link passing through it, about as far as the sphere there) and the image
    border are left out.

    Args:
        depth: (h, w) distance along the optical axis, m, of the same render.
        margin: m; a fraction of the sphere's radius.
    Only the blob's bounding box and a pixel round it are scanned (no neighbour pair outside
    holds a blob pixel): the points of :func:`edges_in` over the whole view, in its order.
    """
    x, y, w, h = cv2.boundingRect(blob.mask.view(np.uint8))
    top, left = max(y - 1, 0), max(x - 1, 0)
    part = (slice(top, y + h + 1), slice(left, x + w + 1))
    points = edges_in(blob.mask[part], depth[part], margin)
    points[:, 0] += left
    points[:, 1] += top
    return points


def edges_in(mask: np.ndarray, depth: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """:func:`outline_edges` of a blob ``mask`` (h, w) bool scanning all of it: points (m, 2)
    (column, row), vertical neighbour pairs first, each in row-major order. With numba
    (``sensing_kernels.ENABLED``) the same points come from a compiled loop."""

    if sensing_kernels.ENABLED:
        return sensing_kernels.outline_edges(mask, depth, float(margin))
    m, z = mask, depth
    points = []
    for axis in (0, 1):
        first = [slice(None), slice(None)]
        second = [slice(None), slice(None)]
        first[axis], second[axis] = slice(None, -1), slice(1, None)
        a, b = tuple(first), tuple(second)
        # (first, second) neighbour pairs along the axis; the outside one must be farther.
        out_second = m[a] & ~m[b] & (z[b] > z[a] + margin)
        out_first = m[b] & ~m[a] & (z[a] > z[b] + margin)
        rows, cols = np.nonzero(out_second | out_first)
        step = (0.5, 0.0) if axis == 0 else (0.0, 0.5)
        points.append(np.stack([cols + step[1], rows + step[0]], axis=-1))
    return np.concatenate(points).astype(float)


def find_sphere(
    rgb: np.ndarray, colour: MarkerColour, center: np.ndarray, focal: np.ndarray
) -> Sighting | None:
    """The sphere of ``colour`` in an image from its blob's pixels, or None if not visible.

    Not visible: no blob, a blob touching the image border (cut), or one that fills less than
    MIN_FILL_RATIO of its convex hull (partly occluded). A thin link crossing into the blob is
    bridged by the convex hull.

    Args:
        rgb: (H, W, 3) uint8 image.
        center: (2,) principal point in pixels; focal: (2,) pixels per normalised unit.
    """
    blob = find_blob(rgb, colour)
    if blob is None or blob.touches_border:
        return None
    rows, cols = np.nonzero(blob.mask)
    y, x = rows.min(), cols.min()
    crop = blob.mask[y : rows.max() + 1, x : cols.max() + 1].astype(np.uint8)
    contours, _ = cv2.findContours(crop, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    hull = cv2.convexHull(np.concatenate(contours))
    filled = crop.copy()
    cv2.fillConvexPoly(filled, hull, 1)
    if blob.count < MIN_FILL_RATIO * filled.sum():
        return None
    centroid, covariance = pixel_moments(filled)
    centroid += (x, y)
    return Sighting(perspective_centre(centroid, covariance, center, focal), float(filled.sum()))


def pixel_moments(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroid (2,) px (column, row) and covariance (2, 2) px² of the pixel centres of a
    binary ``mask`` (h, w) with at least one pixel."""
    m = cv2.moments(mask.astype(np.uint8), binaryImage=True)
    n = m["m00"]
    centroid = np.array([m["m10"] / n, m["m01"] / n])
    covariance = np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / n
    return centroid, covariance


def perspective_centre(
    centroid: np.ndarray, covariance: np.ndarray, center: np.ndarray, focal: np.ndarray
) -> np.ndarray:
    """The image (2,) px of a sphere's centre from its blob pixels' centroid (2,) px and
    covariance (2, 2) px² (see the module docstring)."""
    offset = (centroid - center) / focal  # normalised, y downwards (sign does not matter here)
    rho = float(np.hypot(*offset))
    if rho < 1e-9:
        return centroid
    direction = offset / rho
    scaled = direction / focal  # px -> normalised units along the radial direction
    radial_var = float(scaled @ covariance @ scaled)  # normalised², radial spread
    # Uniform ellipse: variance along the major axis = a²/4; a pixel adds 1/12 px² of its own.
    pixel_var = (scaled**2).sum() / 12.0
    half_axis = 2.0 * np.sqrt(max(radial_var - pixel_var, 0.0))
    phi = 0.5 * (np.arctan(rho - half_axis) + np.arctan(rho + half_axis))
    return center + direction * np.tan(phi) * focal
