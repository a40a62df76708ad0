"""The idealised grasp task: exact marker pixels of the PUMA's hand and of grasp targets.

What ``PumaGrasp-v0`` gives with ``sensing="project", control="kinematic"``, without MuJoCo in
the loop: for joints θ (6,) the hand's frame is DH frame 6 of the closed-form kinematics moved
by :data:`~models.puma560.BASE_POS`, its three markers sit at
:data:`~models.puma560.grasp.MARKER_OFFSETS` in that frame, and the pixels are their exact
pinhole projections through the PUMA scene's two cameras (12 numbers: per marker, in
``MARKER_OFFSETS`` order, ``(u_left, v_left, u_right, v_right)``). Targets are drawn by
:func:`~models.puma560.grasp.sample_grasp_pose`. The exact poses are the independent ground
truth the learners are measured against.
"""

from __future__ import annotations

import numpy as np

from envs.scene import ArmScene
from envs.sensing.stereo import CameraPair
from models.puma560 import BASE_POS, WORKSPACE
from models.puma560.grasp import (
    NARROW,
    OrientationRange,
    marker_points,
    orientation_angle,
    sample_grasp_pose,
)
from models.puma560.kinematics import frames

#: The sensing image of the grasp task, px (width, height).
IMAGE_SIZE = (320, 240)


class PoseOracle:
    """Exact pixels and poses of the PUMA's hand and of grasp targets (see the module docstring).

    Args:
        width, height: the sensing image size, px.
        orientations: the range the targets' orientations are drawn from.
    """

    def __init__(
        self,
        width: int = IMAGE_SIZE[0],
        height: int = IMAGE_SIZE[1],
        orientations: OrientationRange = NARROW,
    ) -> None:
        scene = ArmScene("puma560", 6, width, height)
        self.cameras = CameraPair(scene.stereo.cameras)  # the nominal rig, fixed from here on
        scene.close()
        self.width, self.height = width, height
        self.base = BASE_POS.copy()
        self.orientations = orientations

    def hand_pose(self, theta: np.ndarray) -> np.ndarray:
        """World pose (..., 4, 4) of the hand (DH frame 6) at joints ``theta`` (..., 6)."""
        pose = frames(np.asarray(theta, dtype=float))[..., 6, :, :].copy()
        pose[..., :3, 3] += self.base
        return pose

    def pixels(self, pose: np.ndarray) -> np.ndarray:
        """The 12 marker pixels (..., 12) of frames at world poses ``pose`` (..., 4, 4)."""
        pose = np.asarray(pose, dtype=float)
        points = marker_points(pose)  # (..., 3, 3)
        flat = self.cameras.project(points.reshape(-1, 3))  # (M·3, 4)
        return flat.reshape(*pose.shape[:-2], 12)

    def hand_pixels(self, theta: np.ndarray) -> np.ndarray:
        """The hand's 12 marker pixels (..., 12) at joints ``theta`` (..., 6)."""
        return self.pixels(self.hand_pose(theta))

    def targets(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``n`` grasp targets: world poses (n, 4, 4) and the joints (n, 6) that grasp them."""
        drawn = [sample_grasp_pose(rng, WORKSPACE, self.base, self.orientations) for _ in range(n)]
        return np.stack([d[0] for d in drawn]), np.stack([d[1] for d in drawn])

    def errors(self, target: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Position error (m) and orientation error (rad) of the hand at joints ``theta``
        (..., 6) against target poses (..., 4, 4)."""
        hand = self.hand_pose(theta)
        position = np.linalg.norm(hand[..., :3, 3] - target[..., :3, 3], axis=-1)
        return position, orientation_angle(hand[..., :3, :3], target[..., :3, :3])
