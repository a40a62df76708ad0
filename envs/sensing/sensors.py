"""How a reach env senses its two markers, chosen once at construction: one sensor per mode.

Every sensor has the same two calls, each giving pixels (4,) (u_left, v_left, u_right, v_right),
NaN in a camera that did not see the marker, and visible (2,) bool per camera:

- :meth:`Sensor.sense_target` (the red target, at reset, with the robot out of view),
- :meth:`Sensor.sense_effector` (the green marker at the sensed point, after a move), given
  where the marker is expected (the target's sensed pixels: where a reach aims).

A sensor keeps no GL resources of its own: rendering goes through the scene's
:class:`~envs.sensing.stereo.StereoRig`, whose renderers start at the first rendering, so an
env and its sensor stay picklable.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Protocol

import numpy as np

from envs.sensing.foveated import FoveatedSensing
from envs.sensing.marker_detection import GREEN_EFFECTOR, RED_TARGET
from envs.sensing.stereo import StereoRig

Sighting = tuple[np.ndarray, np.ndarray]  # pixels (4,) px, visible (2,) bool


class SensedScene(Protocol):
    """What a sensor needs of a scene (:class:`envs.scene.ArmScene` has it; sensing sits below
    the environments and does not import them)."""

    stereo: StereoRig
    sensed_site_id: int
    marker_radius: float
    target_radius: float
    fovea: FoveatedSensing


class Sensor(ABC):
    """Senses the target and the effector marker of one scene."""

    #: Whether a sensed centre may lie outside the image (a rendered centre's sub-pixel
    #: perspective correction can shift it out; the env then clips it into the image).
    may_leave_image: bool = True

    @abstractmethod
    def sense_target(self, data) -> Sighting:
        """The target's centre, from ``data`` (positions computed)."""

    @abstractmethod
    def sense_effector(self, data, expected: np.ndarray) -> Sighting:
        """The effector marker's centre; ``expected`` (4,) px is where it is expected (NaN
        where not known)."""


class ProjectSensor(Sensor):
    """The exact pinhole projection of the target's and the sensed site's centres; a camera
    sees a point in front of it that projects inside its image [0, width - 1] × [0, height - 1].

    Args:
        stereo: the scene's rig; site: MuJoCo id of the sensed site.
    """

    may_leave_image = False

    def __init__(self, stereo: StereoRig, site: int) -> None:
        self.stereo, self.site = stereo, site

    def sense_target(self, data) -> Sighting:
        return self._project(data.mocap_pos[0])

    def sense_effector(self, data, expected: np.ndarray) -> Sighting:
        return self._project(data.site_xpos[self.site])

    def _project(self, point: np.ndarray) -> Sighting:
        (u1, v1, u2, v2), (d1, d2) = self.stereo.project_point(point)
        u_max, v_max = self.stereo.width - 1, self.stereo.height - 1
        left = d1 > 0 and 0 <= u1 <= u_max and 0 <= v1 <= v_max
        right = d2 > 0 and 0 <= u2 <= u_max and 0 <= v2 <= v_max
        nan = math.nan
        pixels = [u1, v1, u2, v2] if left and right else [
            u1 if left else nan, v1 if left else nan, u2 if right else nan, v2 if right else nan
        ]  # fmt: skip
        return np.array(pixels), np.array([left, right])


class RenderSensor(Sensor):
    """Both whole camera images rendered and the markers found by colour
    (:meth:`StereoRig.sense`: the target from its blob, the marker from its outline fitted with
    its known radius).

    Args:
        stereo: the scene's rig; marker_radius: the effector marker's radius, m.
    """

    def __init__(self, stereo: StereoRig, marker_radius: float) -> None:
        self.stereo, self.marker_radius = stereo, marker_radius

    def sense_target(self, data) -> Sighting:
        return self.stereo.sense(data, RED_TARGET)

    def sense_effector(self, data, expected: np.ndarray) -> Sighting:
        return self.stereo.sense(data, GREEN_EFFECTOR, self.marker_radius)


class FoveatedSensor(Sensor):
    """Rendering in small dense windows (:class:`FoveatedSensing`): the target from the whole
    images first, then windows where it is; the marker in windows about where it is expected.

    Args:
        fovea: the scene's foveated sensing; marker_radius, target_radius: m.
    """

    def __init__(self, fovea: FoveatedSensing, marker_radius: float, target_radius: float):
        self.fovea = fovea
        self.marker_radius, self.target_radius = marker_radius, target_radius

    def sense_target(self, data) -> Sighting:
        return self.fovea.sense(data, RED_TARGET, self.target_radius)

    def sense_effector(self, data, expected: np.ndarray) -> Sighting:
        return self.fovea.sense(data, GREEN_EFFECTOR, self.marker_radius, expected)


#: Sensing modes, by the name an env's ``sensing`` argument takes.
SENSING_MODES = ("render", "project", "foveated")


def make_sensor(mode: str, scene: SensedScene) -> Sensor:
    """The sensor of ``mode`` (one of SENSING_MODES) for ``scene``."""
    if mode == "project":
        return ProjectSensor(scene.stereo, scene.sensed_site_id)
    if mode == "render":
        return RenderSensor(scene.stereo, scene.marker_radius)
    if mode == "foveated":
        return FoveatedSensor(scene.fovea, scene.marker_radius, scene.target_radius)
    raise ValueError(f"unknown sensing {mode!r}; valid: {', '.join(SENSING_MODES)}")
