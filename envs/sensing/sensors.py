"""How an env senses its markers, chosen once at construction: one sensor per mode.

A task senses M marker spheres on the target (the reach task: the red target; the grasp task:
the object's three) and M on the arm (the green marker; the hand's three). Every sensor has the
same two calls, each giving pixels (4M,) (u_left, v_left, u_right, v_right per marker, in the
task's marker order), NaN in a camera that did not see a marker, and visible (2M,) bool (per
marker, per camera: one flag per (u, v) pair of the pixels):

- :meth:`Sensor.sense_target` (the target's markers, at reset: the reach task's with the robot
  out of view, the grasp task's with everything in view),
- :meth:`Sensor.sense_effector` (the arm's markers, after a move: the reach task's without the
  target, the grasp task's with the object in view), given where they are expected (the
  target's sensed pixels: where a reach or a grasp aims).

Which geom groups a rendering draws follows the marker's colour
(:attr:`~envs.sensing.marker_detection.MarkerColour.together`).

A sensor keeps no GL resources of its own: rendering goes through the scene's
:class:`~envs.sensing.stereo.StereoRig`, whose renderers start at the first rendering, so an
env and its sensor stay picklable.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

from envs.sensing import pinhole_kernels
from envs.sensing.foveated import FoveatedSensing
from envs.sensing.marker_detection import MarkerColour
from envs.sensing.stereo import StereoRig

if TYPE_CHECKING:
    import mujoco  # imported at run time only where used: envs picks the GL back-end first

Sighting = tuple[np.ndarray, np.ndarray]  # pixels (4M,) px, visible (2M,) bool


class SensedMarkers(Protocol):
    """The colours of a task's markers and how the target's are found when rendered
    (:class:`envs.robots.MarkerSet` has them)."""

    effector_colours: tuple[MarkerColour, ...]
    target_colours: tuple[MarkerColour, ...]
    target_outline: bool


class SensedScene(Protocol):
    """What a sensor needs of a scene (:class:`envs.scene.ArmScene` has it; sensing sits below
    the environments and does not import them)."""

    stereo: StereoRig
    markers: SensedMarkers
    effector_geom_ids: np.ndarray
    target_geom_ids: np.ndarray
    marker_radius: float
    target_radius: float
    fovea: FoveatedSensing


def joined(sightings: Sequence[Sighting]) -> Sighting:
    """One sighting (4M,), (2M,) of M markers' sightings (4,), (2,), in their order."""
    if len(sightings) == 1:
        return sightings[0]
    return (
        np.concatenate([pixels for pixels, _ in sightings]),
        np.concatenate([visible for _, visible in sightings]),
    )


class Sensor(ABC):
    """Senses the target's and the effector's markers of one scene."""

    #: Whether a sensed centre may lie outside the image (a rendered centre's sub-pixel
    #: perspective correction can shift it out; the env then clips it into the image).
    may_leave_image: bool = True

    @abstractmethod
    def sense_target(self, data: mujoco.MjData) -> Sighting:
        """The target markers' centres, from ``data`` (positions computed)."""

    @abstractmethod
    def sense_effector(self, data: mujoco.MjData, expected: np.ndarray) -> Sighting:
        """The effector markers' centres; ``expected`` (4M,) px is where they are expected (NaN
        where not known)."""


class ProjectSensor(Sensor):
    """The exact pinhole projection of the marker spheres' centres; a camera sees a point in
    front of it that projects inside its image [0, width - 1] × [0, height - 1].

    Args:
        stereo: the scene's rig; target, effector: MuJoCo ids (M,) of the marker geoms.
    """

    may_leave_image = False

    def __init__(self, stereo: StereoRig, target: np.ndarray, effector: np.ndarray) -> None:
        self.stereo, self.target, self.effector = stereo, target, effector

    def sense_target(self, data: mujoco.MjData) -> Sighting:
        stereo = self.stereo
        return sight(stereo.pixel_projections, data.geom_xpos, self.target, *stereo.pixel_max)

    def sense_effector(self, data: mujoco.MjData, expected: np.ndarray) -> Sighting:
        stereo = self.stereo
        return sight(stereo.pixel_projections, data.geom_xpos, self.effector, *stereo.pixel_max)


def sight(
    projection: np.ndarray, xpos: np.ndarray, ids: np.ndarray, u_max: float, v_max: float
) -> Sighting:
    """Where both cameras see the world points ``xpos[ids]`` (M, 3) m: pixels (4M,) [u1, v1,
    u2, v2 per point], NaN where a camera does not see the point, and per point and camera
    whether it does (2M,): a point in front of the camera (depth > 0) whose image lies in
    [0, u_max] × [0, v_max]. ``projection`` (4, 6): both cameras' pixel projections
    (``CameraPair.pixel_projections``). The compiled kernel when numba is installed, else the
    same operations on arrays."""
    if pinhole_kernels.ENABLED:
        pixels, visible = np.empty(4 * len(ids)), np.empty(2 * len(ids), dtype=bool)
        pinhole_kernels.sight(projection, xpos, ids, u_max, v_max, pixels, visible)
        return pixels, visible
    points = xpos[ids]
    x, y, z = points[:, 0:1], points[:, 1:2], points[:, 2:3]  # (M, 1) each
    h = projection[0] * x + projection[1] * y + projection[2] * z + projection[3]  # (M, 6)
    depth = h[:, 2::3]  # (M, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        u, v = h[:, 0::3] / depth, h[:, 1::3] / depth  # (M, 2) each
    visible = (depth > 0.0) & (0.0 <= u) & (u <= u_max) & (0.0 <= v) & (v <= v_max)
    pixels = np.empty((len(points), 4))
    pixels[:, 0::2], pixels[:, 1::2] = np.where(visible, u, np.nan), np.where(visible, v, np.nan)
    return pixels.reshape(-1), visible.reshape(-1)


class RenderSensor(Sensor):
    """Both whole camera images rendered once per call and every marker found by its colour
    (:meth:`StereoRig.sense_many`: the arm's from their outlines fitted with their known radius,
    the target's from their blobs or, with ``markers.target_outline``, like the arm's).

    Args:
        stereo: the scene's rig; markers: their colours; marker_radius, target_radius: m.
    """

    def __init__(
        self,
        stereo: StereoRig,
        markers: SensedMarkers,
        marker_radius: float,
        target_radius: float,
    ) -> None:
        self.stereo, self.marker_radius = stereo, marker_radius
        self.target_colours = markers.target_colours
        self.effector_colours = markers.effector_colours
        self.target_radius = target_radius if markers.target_outline else None

    def sense_target(self, data: mujoco.MjData) -> Sighting:
        return joined(self.stereo.sense_many(data, self.target_colours, self.target_radius))

    def sense_effector(self, data: mujoco.MjData, expected: np.ndarray) -> Sighting:
        return joined(self.stereo.sense_many(data, self.effector_colours, self.marker_radius))


class FoveatedSensor(Sensor):
    """Rendering in small dense windows (:class:`FoveatedSensing`), one marker at a time: each
    target marker from the whole images first, then windows where it is; each arm marker in
    windows about where it is expected.

    Args:
        fovea: the scene's foveated sensing; markers: their colours; marker_radius,
            target_radius: m; effector: MuJoCo ids (M,) of the arm's marker geoms (where they
            are decides which windows can show them: :meth:`FoveatedSensing.sense_many`).
    """

    def __init__(
        self,
        fovea: FoveatedSensing,
        markers: SensedMarkers,
        marker_radius: float,
        target_radius: float,
        effector: np.ndarray,
    ) -> None:
        self.fovea, self.effector = fovea, effector
        self.target_colours, self.effector_colours = (
            markers.target_colours,
            markers.effector_colours,
        )
        self.marker_radius, self.target_radius = marker_radius, target_radius

    def sense_target(self, data: mujoco.MjData) -> Sighting:
        return joined(self.fovea.sense_many(data, self.target_colours, self.target_radius))

    def sense_effector(self, data: mujoco.MjData, expected: np.ndarray) -> Sighting:
        centres = data.geom_xpos[self.effector]  # (M, 3) m
        return joined(
            self.fovea.sense_many(
                data, self.effector_colours, self.marker_radius, expected, centres
            )
        )


#: Sensing modes, by the name an env's ``sensing`` argument takes.
SENSING_MODES = ("render", "project", "foveated")


def make_sensor(mode: str, scene: SensedScene) -> Sensor:
    """The sensor of ``mode`` (one of SENSING_MODES) for ``scene``."""
    if mode == "project":
        return ProjectSensor(scene.stereo, scene.target_geom_ids, scene.effector_geom_ids)
    if mode == "render":
        return RenderSensor(scene.stereo, scene.markers, scene.marker_radius, scene.target_radius)
    if mode == "foveated":
        return FoveatedSensor(
            scene.fovea,
            scene.markers,
            scene.marker_radius,
            scene.target_radius,
            scene.effector_geom_ids,
        )
    raise ValueError(f"unknown sensing {mode!r}; valid: {', '.join(SENSING_MODES)}")
