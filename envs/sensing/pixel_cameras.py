"""The cameras of the image observations (``obs_mode="pixels"``): a stereo pair placed at run time
that frames the arm's reachable workspace and its targets, apart from the sensing cameras.

The sensing cameras stay as the published figures were measured through them; an agent's small
image needs a view that the workspace fills. The pair stands on the sensing cameras' side of the
workspace (:func:`models.dh_mjcf.frame_pair`, as a generated arm's sensing pair): aimed at the
centre of the sensed point's positions over seeded random joint vectors and of targets drawn from
the robot's workspace, with the field of view that leaves ``margin`` of each image free around
them. In these views the target and marker spheres are drawn at least ``sphere_px`` pixels in
radius wherever they are in the framed workspace (:attr:`PixelRig.sphere_radius`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from envs.sensing.stereo import CameraPair, PinholeCamera
from envs.sensing.viewports import View
from models.dh_mjcf import frame_pair

if TYPE_CHECKING:
    import mujoco  # imported at run time only where used: envs picks the GL back-end first

#: The image observations' cameras, left and right as seen from the cameras.
PIXEL_CAMERAS = ("pix_left", "pix_right")
#: Random joint vectors (and as many targets) whose points the pixel cameras frame.
FRAME_SAMPLES = 1000
FRAME_SEED = 0
#: The framed points lie this fraction of each image's half-size inside its border.
PIXEL_MARGIN = 0.1
#: px: the smallest radius of the target and marker spheres' images in the pixel views.
SPHERE_PX = 2.0
#: rad: the pair looks down at least this steeply, so that the floor fills the background.
MIN_ELEVATION = math.radians(40.0)


class ArmScene(Protocol):
    """What the pixel cameras read of an arm's scene (:class:`envs.scene.ArmScene` has it)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    joint_lower: np.ndarray
    joint_upper: np.ndarray
    stereo: CameraPair
    robot_spec: Any  # envs.robots.RobotSpec: its workspace

    def set_joints(self, q: np.ndarray, data: mujoco.MjData | None = None) -> None: ...

    def sensed_point(self, data: mujoco.MjData | None = None) -> np.ndarray: ...


def random_joints(scene: ArmScene, rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, J) joint vectors drawn uniformly from the controlled joints' ranges, rad."""
    return rng.uniform(scene.joint_lower, scene.joint_upper, size=(n, len(scene.joint_lower)))


def sensed_points(scene: ArmScene, joints: np.ndarray) -> np.ndarray:
    """The sensed point (N, 3) m at each joint vector (N, J), the other joints where the scene
    has them now (the scene's own data is left as it is)."""
    import mujoco

    data = mujoco.MjData(scene.model)
    mujoco.mj_copyData(data, scene.model, scene.data)
    out = np.empty((len(joints), 3))
    for k, q in enumerate(joints):
        scene.set_joints(q, data)
        out[k] = scene.sensed_point(data)
    return out


def frame_points(
    scene: ArmScene, samples: int = FRAME_SAMPLES, seed: int = FRAME_SEED
) -> np.ndarray:
    """What the pixel cameras frame, (2 samples, 3) m: the sensed point at ``samples`` random
    joint vectors and ``samples`` targets drawn from the robot's workspace (seeded)."""
    rng = np.random.default_rng(seed)
    reached = sensed_points(scene, random_joints(scene, rng, samples))
    return np.concatenate([reached, scene.robot_spec.workspace.sample(rng, samples)])


@dataclass(frozen=True)
class PixelRig:
    """The image observations' two cameras at one image size.

    Attributes:
        cameras: left and right (PIXEL_CAMERAS), pinholes of ``height`` × ``width`` images.
        sphere_radius: m, the smallest radius the target and marker spheres are drawn with:
            their images are at least ``sphere_px`` px in radius at the farthest framed point.
    """

    cameras: CameraPair
    sphere_radius: float
    height: int
    width: int

    @classmethod
    def frame(
        cls,
        scene: ArmScene,
        height: int,
        width: int,
        margin: float = PIXEL_MARGIN,
        sphere_px: float = SPHERE_PX,
    ) -> PixelRig:
        """The pair of :func:`frame_pair` about :func:`frame_points`, from the side of the
        sensing cameras' midpoint, for ``height`` × ``width`` images."""
        points = frame_points(scene)
        centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
        sensing = np.mean([c.position for c in scene.stereo.cameras], axis=0)
        back = look_from(sensing - centre)
        centre_px = np.array([width / 2 - 0.5, height / 2 - 0.5])
        cameras = []
        for camera in frame_pair(points, back, margin, width / height):
            f = 0.5 * height / np.tan(np.deg2rad(camera.fovy_deg) / 2)  # px
            rotation = np.stack([camera.right, camera.up, np.cross(camera.right, camera.up)], 1)
            cameras.append(PinholeCamera(camera.pos, rotation, np.array([f, f]), centre_px))
        pair = CameraPair(cameras)
        _, depth = pair.project_with_depth(points)  # (N, 2) m
        radius = sphere_px * float(depth.max()) / float(min(c.focal[0] for c in cameras))
        return cls(pair, radius, height, width)

    def views(self) -> list[View]:
        """Both whole images as posed views (:meth:`View.posed`), named PIXEL_CAMERAS."""
        return [
            View.posed(name, c.position, c.rotation, c.focal, c.center, self.height, self.width)
            for name, c in zip(PIXEL_CAMERAS, self.cameras.cameras, strict=True)
        ]


def look_from(direction: np.ndarray, min_elevation: float = MIN_ELEVATION) -> np.ndarray:
    """The unit direction (3,) of ``direction`` (3,), raised to at least ``min_elevation``
    (rad) above the horizontal."""
    horizontal = float(np.hypot(direction[0], direction[1]))
    elevation = max(math.atan2(direction[2], horizontal), min_elevation)
    side = direction[:2] / horizontal if horizontal > 1e-9 else np.array([1.0, 0.0])
    return np.array([*(side * math.cos(elevation)), math.sin(elevation)])
