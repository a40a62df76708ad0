"""PUMA 560: DH kinematics (Brause Fig. 2b), the reach-target workspace, the pose task and the
robot's :class:`~models.robot_model.RobotModel`."""

from models.puma560.arm import accuracy_chain, tool, wrist
from models.puma560.grasp import grasp_task
from models.puma560.kinematics import ARM_REACH, DH, HOME, frames, wrist_center, wrist_ik
from models.puma560.workspace import (
    BASE_POS,
    WORKSPACE,
    WORKSPACE_BASE_LOWER,
    WORKSPACE_BASE_UPPER,
)
from models.robot_model import RobotModel

#: The PUMA's kinematics: joints 1-3 move the wrist centre, joints 1-6 the tool point.
MODEL = RobotModel(
    name="puma560",
    reach=ARM_REACH,
    workspace=WORKSPACE,
    arms={3: wrist, 6: tool},
    chain=accuracy_chain,
    grasp=grasp_task(),
)

__all__ = [
    "ARM_REACH",
    "BASE_POS",
    "DH",
    "HOME",
    "MODEL",
    "WORKSPACE",
    "WORKSPACE_BASE_LOWER",
    "WORKSPACE_BASE_UPPER",
    "frames",
    "wrist_center",
    "wrist_ik",
]
