"""What an exact controller needs of an arm: forward and inverse kinematics of the sensed point in
world coordinates, its position Jacobian, and the joint ranges.

Each robot's package builds its own (``models/<robot>/arm.py``: the PUMA's wrist centre and tool
point, the RIACS arm's tool point); :func:`arm_kinematics` finds them by robot name through the
robot's :class:`~models.robot_model.RobotModel`.

Every ``inverse`` returns finite joints inside the ranges: a target out of reach is first pulled
radially onto the reachable shell about the shoulder (:func:`pull_to_shell`: the arm stretches
towards it), then angles are wrapped (±2π) or clipped into range; ``reachable`` says whether that
was needed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: Keep pulled-in targets this far (relative) inside the reach limits, so that arccos stays real.
REACH_MARGIN = 1e-9


@dataclass(frozen=True)
class ArmKinematics:
    """Kinematics of an arm's sensed point, vectorised over a leading batch axis.

    Attributes:
        name: robot name (folder under ``models/``).
        lower, upper: joint ranges (J,), rad.
        home: the keyframe ``home`` (J,), rad.
        ready: a well-conditioned pose (J,) in the middle of the target workspace, rad, where
            iterative solvers start (the PUMA ``home`` is the stretched, singular pose of Fig. 2b).
        forward: joints (..., J) -> sensed point (..., 3), world, m.
        jacobian: joints (..., J) -> ∂point/∂joints (..., 3, J), m/rad.
        inverse: (points (N, 3) world, reference (N, J) or None) -> (joints (N, J), reachable
            (N,) bool); joints finite and in range, ``reference`` picks among ±2π turns.
    """

    name: str
    lower: np.ndarray
    upper: np.ndarray
    home: np.ndarray
    ready: np.ndarray
    forward: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    inverse: Callable[[np.ndarray, np.ndarray | None], tuple[np.ndarray, np.ndarray]]

    @property
    def n_joints(self) -> int:
        return len(self.lower)


def pull_to_shell(p: np.ndarray, r_min: float, r_max: float, offset: float = 0.0) -> np.ndarray:
    """Scale points (N, 3) about the origin so that √(|p|² - offset²) lies in [r_min, r_max]
    (the origin itself is moved along +y)."""
    lo, hi = r_min * (1 + REACH_MARGIN), r_max * (1 - REACH_MARGIN)
    norm2 = np.sum(p**2, axis=-1)
    p = np.where((norm2 > 0)[:, None], p, [0.0, 1.0, 0.0])
    norm2 = np.sum(p**2, axis=-1)
    R = np.sqrt(np.maximum(norm2 - offset**2, 0.0))
    target = np.clip(R, lo, hi)
    scale = np.sqrt((target**2 + offset**2) / norm2)
    return np.where((R == target)[:, None], p, p * scale[:, None])


def arm_kinematics(
    robot: str, joints: int = 3, configuration: str = "right-above"
) -> ArmKinematics:
    """The kinematics a controller of ``robot`` with ``joints`` controlled joints needs.

    Args:
        robot: a robot with a model folder (``"puma560"``, ``"riacs"``, ...).
        joints: a count of its :attr:`~models.robot_model.RobotModel.arms` (PUMA: 3 for the
            wrist centre, 6 for the tool point pointing down; RIACS: 3).
        configuration: the PUMA's arm configuration of Brause Fig. 5c (ignored by arms with one
            branch).
    """
    from models.robot_model import robot_model  # it imports this module for ArmKinematics

    return robot_model(robot).arm(joints, configuration)
