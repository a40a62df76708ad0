"""RIACS 3-DOF arm (Jorgensen 1990): report formulas, the reachable workspace and the robot's
:class:`~models.robot_model.RobotModel`."""

import math

import numpy as np

from models.riacs.arm import accuracy_chain, tool
from models.riacs.kinematics import (
    ARM_REACH,
    FOCAL_LENGTH,
    HALF_SEPARATION,
    HOME,
    LINK1,
    LINK2,
    LOWER,
    UPPER,
    camera,
    camerafd,
    robot3df,
    robot3dinv,
)
from models.robot_model import RobotModel
from models.workspace import ReachableWorkspace


def _ik(points: np.ndarray) -> np.ndarray:
    return np.stack(robot3dinv(LINK1, LINK2, *points.T), axis=-1)


def _ik_point(x: float, y: float, z: float) -> tuple[float, float, float]:
    return robot3dinv(LINK1, LINK2, x, y, z, xp=math)


#: The set build3dpts reaches: every point whose robot3dinv lies in the joint ranges.
#: Bounding box from the joint ranges: x, y ∈ [0, 1], z ∈ [-0.40, 0.75] m.
WORKSPACE = ReachableWorkspace(
    lower=np.array([0.0, 0.0, -0.40]),
    upper=np.array([1.0, 1.0, 0.75]),
    ik=_ik,
    ik_point=_ik_point,
    reach=ARM_REACH,  # the shoulder is the origin
    joint_lower=LOWER,
    joint_upper=UPPER,
)

#: The RIACS arm's kinematics: its three joints move the tool point.
MODEL = RobotModel(
    name="riacs", reach=ARM_REACH, workspace=WORKSPACE, arms={3: tool}, chain=accuracy_chain
)

__all__ = [
    "ARM_REACH",
    "FOCAL_LENGTH",
    "HALF_SEPARATION",
    "HOME",
    "LINK1",
    "LINK2",
    "LOWER",
    "MODEL",
    "UPPER",
    "WORKSPACE",
    "camera",
    "camerafd",
    "robot3df",
    "robot3dinv",
]
